"""Compiling the kernels ahead of time: :func:`monovisual3d.warmup`, ``monovisual3d warmup``, the live localizer's
``warmup`` option (issue 56)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

import monovisual3d as mv3d
from monovisual3d import InputError
from monovisual3d.cli import app
from monovisual3d.methods.bayes import _kernels, _residuals
from monovisual3d.methods.bayes.localizer import BayesLocalizer


def test_warmup_prepares_every_bayes_kernel() -> None:
    seconds = mv3d.warmup(["bayes"])
    assert list(seconds) == ["bayes"] and seconds["bayes"] > 0
    for kernel in (_kernels._score_kernel, _kernels._cone_kernel, _kernels._dominated_kernel):
        assert kernel.signatures, kernel  # compiled or loaded: the first localisation does not wait for it
    assert _residuals._box_residuals_kernel.signatures


def test_warmup_rejects_an_unknown_method() -> None:
    with pytest.raises(InputError, match="nope"):
        mv3d.warmup(["nope"])


def test_live_localizer_can_warm_up_at_start() -> None:
    loc = BayesLocalizer(mv3d.Camera.from_hfov(640, 480, 69.0), warmup=True)
    assert loc.views == [] and loc.last is None  # the warm-up leaves no trace in the localizer's state
    assert _kernels._score_kernel.signatures


def test_warmup_command() -> None:
    res = CliRunner().invoke(app, ["warmup", "--methods", "bayes"])
    assert res.exit_code == 0, res.output
    assert "bayes: kernels ready in" in res.stdout


def test_one_command_builds_alone() -> None:
    """``main`` builds only the command it runs (typer would build every command's options first)."""
    import typer.main

    from monovisual3d.cli._app import only_command

    group = typer.main.get_command(only_command(["localize", "session.json", "-q"]))
    assert list(group.commands) == ["localize"]
    assert only_command(["bench", "startup"]) is app  # a group of commands: the whole application
    assert only_command([]) is app and only_command(["--help"]) is app and only_command(["nope"]) is app


def test_main_runs_one_command_in_a_fresh_process(tmp_path: Path) -> None:
    from monovisual3d.examples import example_session_path

    out = tmp_path / "result.json"
    cmd = [sys.executable, "-m", "monovisual3d.cli", "localize", str(example_session_path()), "-q", "-o", str(out)]
    res = subprocess.run(cmd, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert len(json.loads(out.read_text())["objects"]) == 1


def test_warmup_writes_the_package_bytecode() -> None:
    """Python reads bytecode whatever ``PYTHONDONTWRITEBYTECODE`` says: after a warm-up no process compiles the
    package's modules from source again."""
    import importlib.util

    from monovisual3d.api import write_bytecode

    assert write_bytecode()
    for module in (mv3d.api, _kernels):
        assert Path(importlib.util.cache_from_source(module.__file__)).is_file(), module.__name__
