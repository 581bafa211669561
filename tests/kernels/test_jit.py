"""The kernels' compile notice and compile records (:mod:`monovisual3d.kernels.jit`)."""

from __future__ import annotations

import io

import numba

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
