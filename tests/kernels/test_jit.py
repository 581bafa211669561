"""The kernels' compile notice and compile records (:mod:`monovisual3d.kernels.jit`)."""

from __future__ import annotations

import io

import numba
import numpy as np
import pytest

from monovisual3d.kernels.jit import KERNELS, compile_notices, group_of, listen, record_compiles


def _fresh_function() -> object:
    """A new jitted function (never cached): calling it compiles it."""

    @numba.njit
    def add_one(x):  # pragma: no cover - compiled
        return x + 1

    return add_one


def test_record_compiles_names_each_compilation() -> None:
    listen()
    f = _fresh_function()
    with record_compiles() as records:
        assert f(1) == 2
    names = [r.name for r in records if not r.nested]
    assert names == ["test_jit.add_one"]
    assert records[-1].cpu_s > 0 and records[-1].group == "other"


def test_notice_says_once_that_kernels_compile() -> None:
    listen()
    stream = io.StringIO()
    with compile_notices(stream):
        _fresh_function()(1)
        _fresh_function()(2)
    text = stream.getvalue()
    assert text.count("compiling kernels, first run only, about") == 1
    assert "\r" not in text  # no status line where the stream is not a terminal


def test_notice_is_silent_without_compilation() -> None:
    listen()
    f = _fresh_function()
    f(1)
    stream = io.StringIO()
    with compile_notices(stream):
        f(2)  # compiled already: nothing to say
    assert stream.getvalue() == ""


def test_bayes_entry_points_are_registered_by_group() -> None:
    import monovisual3d.methods.bayes._kernels  # noqa: F401
    import monovisual3d.methods.bayes._residuals  # noqa: F401

    assert {"_kernels._score_kernel", "_kernels._cone_kernel", "_residuals._box_residuals_kernel"} <= set(KERNELS["bayes"])
    assert group_of("monovisual3d.methods.bayes._kernels") == "bayes"
    assert group_of("monovisual3d.methods.paper.engine._dense") == "paper"
    assert group_of("monovisual3d.kernels.project") == "paper"


def test_notice_goes_to_stderr_as_it_is_when_compiling(capsys) -> None:  # noqa: ANN001 - pytest fixture
    """By default the notice goes to ``sys.stderr`` at the time of writing (a progress display that captures stderr
    prints it above itself)."""
    listen()
    with compile_notices():
        _fresh_function()(1)
    assert "compiling kernels, first run only" in capsys.readouterr().err


_CACHED_KERNEL = """
import numba


@numba.njit(cache=True, parallel=True)
def sum_of_squares(x):
    s = 0.0
    for i in numba.prange(x.shape[0]):
        s += x[i] * x[i]
    return s
"""

_OTHER_KERNEL = """
import numba


@numba.vectorize(["float64(float64, float64)"], cache=True)
def scaled(x, s):
    return x * s + 1.0
"""

_DRIVER = """
import json, sys
sys.path.insert(0, sys.argv[1])
from monovisual3d.kernels.jit import load_cached_lazily
on = load_cached_lazily(("lazy_kernel_module",))
import numba
import numpy as np
import lazy_kernel_module
loaded = lazy_kernel_module.sum_of_squares(np.arange(1000.0))
lazy = "numba.np.arraymath" not in sys.modules  # numba's numpy implementations left unregistered
typing_lazy = "numba.core.typing.cffi_utils" not in sys.modules  # and the typing declarations (cffi, numpy, ...)
from numba.core.registry import cpu_target
from numba.core.typing import templates
builtins_lazy = templates.builtin_registry not in cpu_target.typing_context._registries  # and the builtin templates
import other_kernel_module  # a user's cached ufunc, not listed: loaded as numba always loads it
ufunc = other_kernel_module.scaled(np.array([1.0, 2.0]), 0.5).tolist()


@numba.njit
def compiled_after(a):  # needs those implementations: registered when it compiles
    return np.sort(a)[0] + np.linalg.norm(a)


after = compiled_after(np.array([3.0, 4.0, 0.0]))
print(json.dumps({"on": on, "loaded": loaded, "lazy": lazy, "typing_lazy": typing_lazy, "builtins_lazy": builtins_lazy, "ufunc": ufunc, "after": after}))
"""


def test_cached_kernels_load_lazily_and_later_compilations_still_work(tmp_path) -> None:  # noqa: ANN001 - pytest
    """A fresh process loads a listed module's cached (parallel) kernel without numba's compile-time registries nor
    its typing declarations (the kernel is typed already), gets its answer, loads another module's cached
    ``@vectorize`` as numba always does (its wrapper is generated without a compilation's refresh), and still compiles
    a kernel that needs the registries afterwards (issue 56)."""
    import json
    import subprocess
    import sys

    (tmp_path / "lazy_kernel_module.py").write_text(_CACHED_KERNEL)
    (tmp_path / "other_kernel_module.py").write_text(_OTHER_KERNEL)
    driver = tmp_path / "driver.py"
    driver.write_text(_DRIVER)
    runs = []
    for _ in range(2):  # the first compiles and caches, the second loads from the cache
        out = subprocess.run([sys.executable, str(driver), str(tmp_path)], capture_output=True, text=True, check=True)
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    expected = float(np.sum(np.arange(1000.0) ** 2))
    for run in runs:
        assert run["on"] is True
        assert run["loaded"] == pytest.approx(expected, rel=1e-12)
        assert run["after"] == pytest.approx(5.0, rel=1e-12)
        assert run["ufunc"] == pytest.approx([1.5, 2.0], rel=1e-12)
    assert runs[0]["lazy"] is False  # compiling registered everything
    assert runs[0]["typing_lazy"] is False and runs[0]["builtins_lazy"] is False
    assert runs[1]["lazy"] is True  # the cached load did not
    assert runs[1]["typing_lazy"] is True and runs[1]["builtins_lazy"] is True
