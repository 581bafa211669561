"""Shared fixtures of the batch tests: a few small simulated sessions with ground truth, and bad ones."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest

from monovisual3d.sim.scenes import paper_scene
from monovisual3d.sim.simulate import write_simulation

try:  # the [dask] extra (in [dev]); without it these tests are not collected
    import distributed  # noqa: F401
    import pandas  # noqa: F401
    import pyarrow  # noqa: F401
except ImportError:  # pragma: no cover - depends on the environment
    collect_ignore_glob = ["test_*.py"]

#: A fast localisation: the paper method on a coarse grid (numpy backend, no compilation).
FAST: dict[str, Any] = {"method": "paper", "resolution": 0.05}

#: Columns that differ from run to run (timing, which worker).
VOLATILE = ["runtime_s", "worker"]


@pytest.fixture(scope="session")
def sim_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``runs/{a/s0, a/s1, b/s2}/session.json`` + ``truth.json``: three noise-free paper-scene sessions."""
    root = tmp_path_factory.mktemp("sim") / "runs"
    for seed, sub in enumerate(("a/s0", "a/s1", "b/s2")):
        write_simulation(root / sub, paper_scene(), rng=seed, images=False)
    return root


@pytest.fixture
def runs(sim_root: Path, tmp_path: Path) -> Path:
    """A private copy of :func:`sim_root` that a test may change."""
    return Path(shutil.copytree(sim_root, tmp_path / "runs"))


def add_bad_sessions(root: Path) -> Path:
    """Add a corrupt, an empty and an invalid session under ``root/bad``."""
    for name, text in (("corrupt", '{"camera": {"width": 640,'), ("empty", ""), ("invalid", '{"views": []}')):
        (root / "bad" / name).mkdir(parents=True)
        (root / "bad" / name / "session.json").write_text(text)
    return root


@pytest.fixture
def mixed(runs: Path) -> Path:
    """:func:`runs` plus a corrupt, an empty and an invalid session."""
    return add_bad_sessions(runs)


@pytest.fixture(scope="session")
def mixed_root(sim_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of :func:`sim_root` with the bad sessions of :func:`mixed`, shared by the tests that only read it."""
    return add_bad_sessions(Path(shutil.copytree(sim_root, tmp_path_factory.mktemp("mixed") / "runs")))


@pytest.fixture(scope="session")
def reference(mixed_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The tables of the batch over :func:`mixed_root`, run in this process."""
    from monovisual3d.batch import run

    return run([mixed_root], tmp_path_factory.mktemp("reference") / "out", workers=0, **FAST)


def comparable(df: Any) -> Any:
    """The table without the columns that change from run to run."""
    return df.drop(columns=[c for c in VOLATILE if c in df.columns])
