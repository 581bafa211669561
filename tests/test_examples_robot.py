"""``examples/robot/``: the import command of docs/robot.md, run as written, gives a session whose fruit are the truth's.

Also: the folder is consistent (image size, one pose and one label file per image) and small, and the
README's demo figure is the one ``demo`` quotes.
"""

from __future__ import annotations

import json
import re
import shlex
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from monovisual3d import evaluate, localize
from monovisual3d.cli import app
from monovisual3d.experiments.demo import README_MEAN_ERROR_MM, README_SEEDS
from monovisual3d.io.calibration import read_calibration

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "robot"
#: The import line of docs/robot.md (and of the README's Use section).
IMPORT_LINE = re.compile(r"^monovisual3d import .*examples/robot/.*$", re.MULTILINE)
#: Largest size of the example folder, bytes.
MAX_FOLDER_BYTES = 200_000
#: Every fruit must be found within this distance of the truth, metres (the example has 2 % box noise).
MAX_ERROR_M = 0.01


def _docs_command() -> list[str]:
    (line,) = IMPORT_LINE.findall((ROOT / "docs" / "robot.md").read_text())
    return shlex.split(line)


def test_readme_has_the_same_import_line() -> None:
    readme = (ROOT / "README.md").read_text()
    assert " ".join(_docs_command()) in readme


def test_docs_import_command_runs_as_written_and_finds_the_fruit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    shutil.copytree(EXAMPLE, tmp_path / "examples" / "robot", ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.chdir(tmp_path)  # the command's paths are relative to the repository root
    argv = _docs_command()
    assert argv[0] == "monovisual3d"
    result = CliRunner().invoke(app, argv[1:])
    assert result.exit_code == 0, result.output
    assert "detections: 36" in result.stdout and "matched poses to detections by file name" in result.stdout
    session = Path(argv[argv.index("--output") + 1])
    truth = json.loads((tmp_path / "examples" / "robot" / "truth.json").read_text())["objects"]
    found = localize(session)
    m = evaluate(found.positions, [t["position"] for t in truth], truth_radii=[t["radius"] for t in truth])
    assert m.recall == 1.0 and m.precision == 1.0
    assert m.euclidean_max < MAX_ERROR_M


def test_example_folder_is_consistent_and_small() -> None:
    camera = read_calibration(EXAMPLE / "camera.yaml")
    assert camera.size == (640, 480)
    images = sorted(p.stem for p in (EXAMPLE / "images").glob("*.png"))
    labels = sorted(p.stem for p in (EXAMPLE / "labels").glob("img_*.txt"))
    poses = (EXAMPLE / "poses.csv").read_text().splitlines()[1:]
    assert images == labels and len(poses) == len(images) >= 3
    assert [row.split(",")[0].removesuffix(".png") for row in poses] == images
    for name in images:  # PNG header: width and height, big-endian, at bytes 16..24
        header = (EXAMPLE / "images" / f"{name}.png").read_bytes()[16:24]
        assert (int.from_bytes(header[:4], "big"), int.from_bytes(header[4:], "big")) == camera.size
    for label in (EXAMPLE / "labels").glob("img_*.txt"):
        values = np.array([line.split()[1:5] for line in label.read_text().splitlines()], dtype=float)
        assert np.all((values > 0) & (values < 1)), label
    size = sum(p.stat().st_size for p in EXAMPLE.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    assert size < MAX_FOLDER_BYTES


def test_readme_demo_row_is_the_figure_demo_quotes() -> None:
    row = next(line for line in (ROOT / "README.md").read_text().splitlines() if line.startswith("| greenhouse + box noise"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert f"seeds {README_SEEDS}" in cells[0]
    assert cells[1] == f"{README_MEAN_ERROR_MM['bayes']:g} mm"
    assert cells[3] == f"{README_MEAN_ERROR_MM['paper']:g} mm"
