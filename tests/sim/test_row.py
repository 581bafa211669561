"""The plant-row scene and views (issue 22): ``simulate --scene row --views row:N``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from monovisual3d import load_session
from monovisual3d.cli import app
from monovisual3d.errors import InputError
from monovisual3d.sim.row import row_camera, row_scene
from monovisual3d.sim.scenes import scene_by_name
from monovisual3d.sim.viewpoints import poses_by_name, row_poses

runner = CliRunner()


def test_row_scene_fills_the_row_without_overlap():
    s = row_scene(96, rng=3)
    c, r = s.centres, s.radii
    assert len(s.fruits) == 96 and s.name == "row"
    assert np.all((r >= 0.02) & (r <= 0.04))
    half = np.array([0.125, 0.6, 0.35])
    assert np.all(np.abs(c - [0.6, 0.0, 0.45]) + r[:, None] <= half + 1e-12)
    d = np.linalg.norm(c[:, None] - c[None], axis=-1) + 10 * np.eye(96)
    assert np.all(d >= r[:, None] + r[None])
    assert_allclose(row_scene(96, rng=3).centres, c)  # seeded
    ws = s.metadata["workspace"]
    assert np.all(np.asarray(ws["min"]) < c.min(axis=0)) and np.all(np.asarray(ws["max"]) > c.max(axis=0))
    assert len(row_scene(10, rng=0, length=0.5).fruits) == 10
    assert scene_by_name("row", 0).name == "row" and len(scene_by_name("row", 0, n_fruit=5).fruits) == 5


def test_row_scene_bad_input():
    with pytest.raises(InputError, match="n_fruit: got 0"):
        row_scene(0)
    with pytest.raises(InputError, match="length: got -1"):
        row_scene(5, length=-1.0)
    with pytest.raises(InputError, match="at most"):
        row_scene(10_000)


def test_row_poses_look_straight_at_the_row_from_along_it():
    P = row_poses(5, length=1.2, distance=0.8)
    assert_allclose(P[:, 1, 3], [0.6, 0.3, 0.0, -0.3, -0.6])
    assert_allclose(P[:, 0, 3], -0.2)  # 0.8 m in front of the row's centre plane at x = 0.6
    assert_allclose(P[:, :3, 2], np.tile([1.0, 0.0, 0.0], (5, 1)), atol=1e-12)
    assert_allclose(poses_by_name("row:5", distance=0.8), P)
    assert_allclose(poses_by_name("row:1", distance=0.5)[0, :3, 3], [0.1, 0.0, 0.45])
    with pytest.raises(InputError, match="row:N with N an integer"):
        poses_by_name("row:x")
    with pytest.raises(InputError, match="N >= 1"):
        poses_by_name("row:0")
    cam = row_camera()
    assert (cam.width, cam.height) == (1280, 720) and cam.fx == pytest.approx(640.0)


def test_simulate_row_from_the_cli(tmp_path):
    out = tmp_path / "row"
    args = ["simulate", "-o", str(out), "--scene", "row", "--n-fruit", "20", "--views", "row:4", "--noise", "0.03"]
    result = runner.invoke(app, [*args, "--no-images", "--seed", "2", "--row-length", "1.0"])
    assert result.exit_code == 0, result.output
    session = load_session(out / "session.json")
    assert (session.camera.width, session.camera.height) == (1280, 720) and len(session.views) == 4
    assert session.workspace is not None
    truth = json.loads((out / "truth.json").read_text())
    ys = np.array([o["position"][1] for o in truth["objects"]])
    assert len(ys) == 20 and np.all(np.abs(ys) <= 0.5)
    assert_allclose([v.T_base_optical[1, 3] for v in session.views], [0.5, 1 / 6, -1 / 6, -0.5])


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--scene", "paper", "--row-length", "2"], "--row-length: only for --scene row"),
        (["--scene", "row", "--image-size", "big"], "--image-size: got 'big'"),
        (["--scene", "row", "--views", "row:x"], "row:N with N an integer"),
        (["--scene", "row", "--n-fruit", "0"], "--n-fruit: got 0"),
    ],
)
def test_simulate_row_bad_flags_are_one_line(tmp_path, extra, message):
    result = runner.invoke(app, ["simulate", "-o", str(tmp_path / "x"), "--no-images", *extra])
    assert result.exit_code == 2
    assert message in result.output and "Traceback" not in result.output
