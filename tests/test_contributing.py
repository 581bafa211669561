"""CONTRIBUTING.md works: its toy method, written to a temporary module, registers and runs through the CLI."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

import monovisual3d
from monovisual3d.errors import InputError
from monovisual3d.methods import METHODS, register_method
from monovisual3d.sim.scenes import random_scene
from monovisual3d.sim.simulate import simulate

ROOT = Path(__file__).resolve().parent.parent
GUIDE = ROOT / "CONTRIBUTING.md"
#: The toy's rays go through box centres, not the projected sphere centres: 0.5-1.8 mm off on seeds 0-4.
TOY_TOLERANCE_M = 0.005


def guide_file(name: str) -> str:
    """The code block that follows ``<!-- name -->`` in CONTRIBUTING.md."""
    m = re.search(rf"<!-- {re.escape(name)} -->\n```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert m is not None, f"CONTRIBUTING.md has no code block for {name}"
    return m.group(1)


@pytest.fixture
def guide_modules(tmp_path: Path) -> Path:
    """The guide's toy method and its registration as modules in ``tmp_path``."""
    for name in ("toy_method.py", "register_toy.py"):
        (tmp_path / name).write_text(guide_file(name))
    return tmp_path


def _cli(modules: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """``monovisual3d ARGS`` in a fresh process that ran the guide's registration before building the CLI."""
    path = [str(modules), str(Path(monovisual3d.__file__).parent.parent), os.environ.get("PYTHONPATH", "")]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in path if p)}
    code = "import register_toy\nfrom monovisual3d.cli import main\nmain()"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=env, timeout=300)


def test_the_toy_method_of_the_guide_runs_through_the_cli(guide_modules: Path, tmp_path: Path) -> None:
    scene = random_scene(1, rng=3)
    session, _ = simulate(scene, rng=3)
    session.to_json(tmp_path / "session.json")

    help_text = _cli(guide_modules, "localize", "--help-all")
    assert help_text.returncode == 0, help_text.stderr
    assert "--first-views" in help_text.stdout and "Expert: toy method" in help_text.stdout
    table = _cli(guide_modules, "options", "toy")
    assert table.returncode == 0, table.stderr
    assert "first_views" in table.stdout and "--first-views" in table.stdout

    session_path, result_path = str(tmp_path / "session.json"), str(tmp_path / "result.json")
    out = _cli(guide_modules, "localize", session_path, "--method", "toy", "--first-views", "2", "-q", "-o", result_path)
    assert out.returncode == 0, out.stderr
    result = json.loads((tmp_path / "result.json").read_text())
    assert result["method"] == "toy" and result["config"]["first_views"] == 2
    assert len(result["objects"]) == 1
    assert_allclose(result["objects"][0]["position"], scene.centres[0], atol=TOY_TOLERANCE_M)


def test_the_toy_method_refuses_bad_options_in_cli_words(guide_modules: Path, tmp_path: Path) -> None:
    session, _ = simulate(random_scene(1, rng=3), rng=3)
    session.to_json(tmp_path / "session.json")
    out = _cli(guide_modules, "localize", str(tmp_path / "session.json"), "--method", "toy", "--first-views", "1")
    assert out.returncode == 2
    assert "--first-views: got 1, expected at least 2 views" in out.stderr + out.stdout
    out = _cli(guide_modules, "localize", str(tmp_path / "session.json"), "--method", "toy", "--kernel", "square")
    assert out.returncode == 2 and "--kernel: not an option of --method toy" in out.stderr + out.stdout


def test_register_method_checks_its_arguments() -> None:
    with pytest.raises(InputError, match="already registered"):
        register_method("paper", "again", "monovisual3d.methods.paper.config:PaperConfig", "monovisual3d.methods.paper.run:run")
    with pytest.raises(InputError, match="method name"):
        register_method("Toy Method", "bad name", "a:B", "a:run")
    with pytest.raises(InputError, match="run_path"):
        register_method("toy-bad-path", "bad path", "a:B", "a.run")
    assert "toy-bad-path" not in METHODS


def test_the_toy_runs_from_python_after_registration(guide_modules: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(guide_modules))
    register_method("toy-py", "the guide's toy", "toy_method:ToyConfig", "toy_method:run")
    try:
        scene = random_scene(1, rng=5)
        session, _ = simulate(scene, rng=5)
        result = monovisual3d.localize(session, method="toy-py")
        assert result.method == "toy" and len(result.objects) == 1
        assert np.linalg.norm(result.objects[0].position - scene.centres[0]) < TOY_TOLERANCE_M
    finally:
        METHODS.pop("toy-py", None)


@pytest.fixture
def bench_modules(tmp_path: Path) -> Path:
    """The guide's toy bench and its registration as modules in ``tmp_path``."""
    for name in ("toy_bench.py", "register_toy_bench.py"):
        (tmp_path / name).write_text(guide_file(name))
    return tmp_path


def _bench_cli(modules: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """``monovisual3d ARGS`` in a fresh process that registered the guide's toy bench first."""
    path = [str(modules), str(Path(monovisual3d.__file__).parent.parent), os.environ.get("PYTHONPATH", "")]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in path if p)}
    code = "import register_toy_bench\nfrom monovisual3d.cli import main\nmain()"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=env, timeout=300)


def test_the_toy_bench_of_the_guide_runs_through_the_cli(bench_modules: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert "toy" in _bench_cli(bench_modules, "bench", "--help").stdout
    out = _bench_cli(bench_modules, "bench", "toy", "--seeds", "2")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert [line.split(":")[0] for line in lines] == ["seed 0", "seed 1"]
    monkeypatch.syspath_prepend(str(bench_modules))
    from toy_bench import run_toy_bench  # the measurement itself, from Python: the same numbers

    result = run_toy_bench(range(2))
    assert set(result["meta"]) >= {"cpu", "cores"}
    for line, row in zip(lines, result["rows"]):
        assert line == f"seed {row['seed']}: mean {row['mean_mm']:.2f} mm, recall {row['recall']:.3f}"
        assert row["recall"] == 1.0 and 0 < row["mean_mm"] < 20  # the paper scene's fruit are found, a few mm off
    bad = _bench_cli(bench_modules, "bench", "toy", "--seeds", "0")
    assert bad.returncode == 2 and "--seeds" in bad.stderr
