"""``monovisual3d demo``: runs with no arguments, writes its files, finds the fruit."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from monovisual3d import load_session
from monovisual3d.cli import app
from monovisual3d.errors import InputError
from monovisual3d.experiments.demo import README_MEAN_ERROR_MM, run_demo
from monovisual3d.truth import load_objects

#: Bound on the demo's mean error (bayes, default seed 0, paper noise). Measured: 7.0 mm mean, 12.9 mm max, recall 1.0
#: (10 fruit); the bound leaves a 2x margin and fails if the method or the simulator regresses to ghost-level errors.
MAX_MEAN_ERROR_M = 0.015


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    out = tmp_path_factory.mktemp("demo") / "mv3d-demo"
    result = CliRunner().invoke(app, ["demo", "--output", str(out)])
    return out, result


def test_demo_succeeds_and_prints_tables(demo_run: tuple[Path, object]) -> None:
    out, result = demo_run
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    text = result.output  # type: ignore[attr-defined]
    assert "Localised fruit" in text and "Errors vs. truth" in text
    assert "Euclidean mean (mm)" in text and "recall" in text
    assert "Found " in text and str(out / "result.json") in "".join(text.split())


def test_demo_text_is_not_wrapped_when_stdout_is_not_a_terminal(demo_run: tuple[Path, object]) -> None:
    _, result = demo_run
    lines = result.stdout.splitlines()  # type: ignore[attr-defined]
    intro = next(line for line in lines if line.startswith("monovisual3d demo (seed 0)"))
    assert intro.endswith("with the 'bayes' method from the 2D boxes alone..."), intro
    scene = next(line for line in lines if line.startswith("Scene: "))
    assert scene.endswith("% missed)."), scene
    assert any(line.endswith("- what the camera saw, with the detected boxes numbered as in session.json") for line in lines)


def test_demo_writes_its_files(demo_run: tuple[Path, object]) -> None:
    out, _ = demo_run
    for name in ("session.json", "truth.json", "result.json", "scene.json"):
        assert (out / name).is_file(), name
    session = load_session(out / "session.json")
    assert len(session.views) == 3
    assert sorted(p.name for p in out.glob("view_*.png")) == ["view_00.png", "view_01.png", "view_02.png"]
    pytest.importorskip("matplotlib")
    assert (out / "scene.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_demo_finds_the_fruit(demo_run: tuple[Path, object]) -> None:
    out, _ = demo_run
    from monovisual3d.metrics import evaluate

    truth = load_objects(out / "truth.json")
    est = load_objects(out / "result.json")
    assert 5 <= len(truth.positions) <= 10
    m = evaluate(est.positions, truth.positions, truth_radii=truth.radii, estimate_radii=est.radii)
    assert m.recall >= 0.8, m
    assert m.precision >= 0.8, m
    assert m.euclidean_mean < MAX_MEAN_ERROR_M, m
    # the result file is the library's JSON with radii (the default method estimates size)
    data = json.loads((out / "result.json").read_text())
    assert data["method"] == "bayes"
    assert all("radius" in o for o in data["objects"])


def test_demo_same_seed_same_result(tmp_path: Path) -> None:
    a = run_demo(tmp_path / "a", seed=3, figure=False)
    b = run_demo(tmp_path / "b", seed=3, figure=False)
    assert (tmp_path / "a" / "truth.json").read_text() == (tmp_path / "b" / "truth.json").read_text()
    assert a.result.positions.tolist() == b.result.positions.tolist()


def test_demo_rejects_bad_input(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="method"):
        run_demo(tmp_path, method="nope", figure=False)
    result = CliRunner().invoke(app, ["demo", "--output", str(tmp_path / "x"), "--method", "nope"])
    assert result.exit_code == 2
    assert result.stderr.startswith("error: --method (method): got 'nope', expected one of ['bayes', 'paper', 'quadric']")
    assert result.stdout == ""  # validated before the intro is printed
    assert not (tmp_path / "x").exists()
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match="not a directory"):
        run_demo(tmp_path / "file", figure=False)


def test_demo_quotes_its_seed_beside_the_readme_mean(demo_run: tuple[Path, object]) -> None:
    _, result = demo_run
    line = next(line for line in result.stdout.splitlines() if line.startswith("Found "))  # type: ignore[attr-defined]
    readme = re.escape(f"{README_MEAN_ERROR_MM['bayes']:g}")  # equal to the README's row (test_examples_robot)
    assert re.search(rf"mean error \d+\.\d mm on this seed \(0\); the README's {readme} mm is the mean over all fruit", line), (
        line
    )
    assert "seeds 0..19 of `monovisual3d bench accuracy`, condition greenhouse-noise" in line
