"""Compiling the kernels ahead of time: :func:`monovisual3d.warmup`, ``monovisual3d warmup``, the live localizer's
``warmup`` option (issue 56)."""

from __future__ import annotations

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
