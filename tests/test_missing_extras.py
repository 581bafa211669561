"""A command whose optional dependency is not installed says which extra to install, in one line, exit code 2."""

from __future__ import annotations

import builtins
import importlib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from cli_checks import assert_one_line_error
from monovisual3d import _extras
from monovisual3d.cli import app
from monovisual3d.errors import MissingExtra
from monovisual3d.examples import example_session_path


@pytest.fixture
def without(monkeypatch: pytest.MonkeyPatch):
    """``without(*modules)``: those modules (and their submodules) cannot be imported, as when their extra is missing."""

    def hide(*modules: str) -> None:
        def hidden(name: str) -> bool:
            return any(name == m or name.startswith(m + ".") for m in modules)

        real_module, real_import = importlib.import_module, builtins.__import__

        def import_module(name: str, package: str | None = None):
            if hidden(name):
                raise ModuleNotFoundError(f"No module named {name!r}")
            return real_module(name, package)

        def import_(name: str, globals=None, locals=None, fromlist=(), level: int = 0):  # a plain import statement
            if level == 0 and hidden(name):
                raise ModuleNotFoundError(f"No module named {name!r}")
            return real_import(name, globals, locals, fromlist, level)

        monkeypatch.setattr(_extras.importlib, "import_module", import_module)
        monkeypatch.setattr(builtins, "__import__", import_)

    return hide


def test_require_names_the_extra(without) -> None:
    without("distributed")
    with pytest.raises(MissingExtra, match=r"distributed is needed .*monovisual3d\[dask\]"):
        _extras.require("distributed", "dask")


def test_batch_without_its_table_libraries_does_no_work_and_leaves_nothing(without, tmp_path: Path) -> None:
    without("pandas", "pyarrow")
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["batch", str(example_session_path()), "-o", str(out), "--workers", "0"])
    assert_one_line_error(result, "pandas is needed", "monovisual3d[dask]")
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize(
    ("args", "modules", "fragments"),
    [
        (["bench", "accuracy", "--quick", "--only", "paper-clean", "--workers", "2"], ("distributed",), ("monovisual3d[dask]",)),
        (
            ["localize", str(example_session_path()), "--method", "paper", "--backend", "torch"],
            ("torch",),
            ("monovisual3d[gpu]",),
        ),
        (
            ["import-bag", "no.bag", "--base-frame", "base", "--camera-frame", "cam", "--detections", "/det", "-o", "s.json"],
            ("rosbags",),
            ("monovisual3d[ros]",),
        ),
    ],
    ids=["bench-workers", "torch-backend", "import-bag"],
)
def test_a_missing_extra_is_one_line(without, tmp_path: Path, monkeypatch, args, modules, fragments) -> None:
    monkeypatch.chdir(tmp_path)
    without(*modules)
    assert_one_line_error(CliRunner().invoke(app, args), *fragments)


@pytest.mark.parametrize(
    "args", [["ros2", "node", "--no-warmup"], ["ros2", "play", str(example_session_path())]], ids=["ros2-node", "ros2-play"]
)
def test_ros2_without_cyclonedds_names_the_extra(without, monkeypatch, args) -> None:
    import sys

    for name in [m for m in sys.modules if m.startswith("monovisual3d.ros2")]:
        monkeypatch.delitem(sys.modules, name)  # imported by other tests: import them afresh, as in a new process
    without("cyclonedds")
    assert_one_line_error(CliRunner().invoke(app, args), "cyclonedds", "monovisual3d[ros2]")
