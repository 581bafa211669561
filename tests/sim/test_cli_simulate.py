"""`monovisual3d simulate` end to end."""

from __future__ import annotations

import json

import numpy as np
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from monovisual3d import load_session
from monovisual3d.cli import app
from monovisual3d.sim.scenes import paper_scene, random_scene
from monovisual3d.truth import load_objects

runner = CliRunner()


def test_simulate_paper_scene(tmp_path):
    out = tmp_path / "paper"
    result = runner.invoke(app, ["simulate", "--scene", "paper", "--output", str(out)])
    assert result.exit_code == 0, result.output
    session = load_session(out / "session.json")
    assert len(session.views) == 3 and all(len(v.detections) == 6 for v in session.views)
    assert_allclose(load_objects(out / "truth.json").positions, paper_scene().centres)
    assert (out / "view_02.png").exists() and (out / "scene.json").exists()


def test_simulate_with_all_options_is_reproducible(tmp_path):
    args = [
        "simulate",
        "--scene",
        "random",
        "--n-fruit",
        "3",
        "--views",
        "ring:4:25",
        "--noise",
        "0.05",
        "--drop",
        "0.02",
        "--false-positives",
        "0.5",
        "--pose-error-mm",
        "2",
        "--pose-error-deg",
        "0.5",
        "--seed",
        "4",
        "--no-images",
    ]
    r1 = runner.invoke(app, [*args, "--output", str(tmp_path / "a")])
    r2 = runner.invoke(app, [*args, "--output", str(tmp_path / "b")])
    assert r1.exit_code == 0 and r2.exit_code == 0, r1.output + r2.output
    a = (tmp_path / "a" / "session.json").read_text()
    assert a == (tmp_path / "b" / "session.json").read_text()
    truth = json.loads((tmp_path / "a" / "truth.json").read_text())
    assert len(truth["objects"]) == 3 and len(truth["views"]) == 4
    assert truth["noise"]["pose_position_std"] == 0.002
    assert truth["noise"]["hand_eye_position_std"] == 0.0  # none asked for
    assert truth["hand_eye_error"] is None
    assert_allclose(truth["noise"]["pose_rotation_std"], np.radians(0.5))
    assert not list((tmp_path / "a").glob("*.png"))
    r3 = runner.invoke(app, [*args[:-3], "--seed", "5", "--no-images", "--output", str(tmp_path / "c")])
    assert r3.exit_code == 0 and (tmp_path / "c" / "session.json").read_text() != a


def test_simulate_a_scene_file(tmp_path):
    scene = random_scene(2, rng=0)
    scene.save(tmp_path / "my_scene.json")
    result = runner.invoke(app, ["simulate", "--scene", str(tmp_path / "my_scene.json"), "--output", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert_allclose(load_objects(tmp_path / "o" / "truth.json").positions, scene.centres)


def test_simulate_rejects_bad_options(tmp_path):
    cases = [
        (["--scene", "orchard"], "scene: got 'orchard'"),
        (["--views", "ring:x"], "ring:N"),
        (["--views", "cube:3"], "--views: got 'cube:3'"),
        (["--views", "ring:0"], "--views: got 'ring:0', expected ring:N with N >= 1 views"),
        (["--views", "hemisphere:5:120"], "--views: got 'hemisphere:5:120', expected the largest angle"),
        (["--distance", "0"], "--distance (distance): got 0.0"),
        (["--drop", "1.5"], "--drop (noise.drop_probability): got 1.5"),
        (["--noise", "-0.1"], "--noise (noise.box_sigma): got -0.1"),
        (["--false-positives", "-1"], "--false-positives (noise.false_positive_rate): got -1.0"),
        (["--pose-error-mm", "-1"], "--pose-error-mm (pose_error_mm): got -1.0"),
        (["--hand-eye-error-mm", "-1"], "--hand-eye-error-mm (hand_eye_error_mm): got -1.0"),
        (["--hand-eye-error-deg", "200"], "--hand-eye-error-deg (hand_eye_error_deg): got 200, more than"),
        (["--scene", "paper", "--n-fruit", "2"], "paper scene has 6 spheres"),
        (["--scene", "random", "--n-fruit", "0"], "--n-fruit: got 0"),
        (["--hfov-deg", "200"], "--hfov-deg: got 200.0, expected degrees in (0, 180)"),
        (["--supersample", "0"], "--supersample (supersample): got 0"),
    ]
    for extra, message in cases:
        result = runner.invoke(app, ["simulate", *extra, "--output", str(tmp_path / "x")])
        assert result.exit_code == 2, (extra, result.output)
        assert message in result.output, (extra, result.output)
        assert "Traceback" not in result.output


def test_simulate_scene_file_errors_name_the_file_once_and_say_what_a_scene_needs(tmp_path):
    def error(path):
        result = runner.invoke(app, ["simulate", "--scene", str(path), "--output", str(tmp_path / "x")])
        assert result.exit_code == 2, result.output
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"error: {path}: "), result.stderr
        return lines[0].removeprefix(f"error: {path}: ")

    assert error(tmp_path / "missing_scene.json") == "file not found"
    session = {"camera": {"width": 640, "height": 480, "hfov_deg": 69}, "views": []}
    (tmp_path / "session.json").write_text(json.dumps(session))
    message = error(tmp_path / "session.json")
    assert message.startswith('a session file (it has \'views\'), not a scene; a scene file holds {"objects": [{"position"')
    (tmp_path / "bad.json").write_text(json.dumps({"objects": [{"position": [0.6, 0, 0.4], "radius": -1}]}))
    assert error(tmp_path / "bad.json") == "objects[0].radius: expected a positive number of metres, got -1"
    (tmp_path / "leaf.json").write_text(json.dumps({"objects": [], "occluders": [{"type": "leaf", "centre": [0, 0, 0]}]}))
    assert error(tmp_path / "leaf.json").startswith("occluders[0].axis_u: missing field, a leaf needs ['centre', 'axis_u'")


def test_simulate_with_a_hand_eye_error_writes_it_and_shares_it_between_views(tmp_path):
    from monovisual3d import load_session

    out = tmp_path / "he"
    args = ["simulate", "--hand-eye-error-mm", "1", "--hand-eye-error-deg", "0.3", "--no-images", "--output", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    truth = json.loads((out / "truth.json").read_text())
    assert truth["noise"]["hand_eye_position_std"] == 0.001
    assert_allclose(truth["noise"]["hand_eye_rotation_std"], np.radians(0.3))
    session = load_session(out / "session.json")
    true_poses = [np.asarray(v["T_base_optical_true"], dtype=float) for v in truth["views"]]
    E = [np.linalg.inv(T) @ v.T_base_optical for T, v in zip(true_poses, session.views)]
    assert_allclose(E[1], E[0], atol=1e-9)
    assert np.linalg.norm(E[0][:3, 3]) > 1e-5
    assert_allclose(truth["hand_eye_error"], E[0], atol=1e-9)  # the drawn error is in the truth


def test_simulate_time_offset_writes_the_pose_stream_that_import_reads(tmp_path):
    """--time-offset on an arc: poses one frame late in the session, and poses.csv/detections.csv import back to it."""
    out = tmp_path / "late"
    args = ["simulate", "--scene", "random", "--n-fruit", "3", "--views", "arc:5:60", "--no-images", "-o", str(out)]
    result = runner.invoke(app, [*args, "--time-offset", "0.25", "--frame-rate", "4", "--noise", "0.03"])
    assert result.exit_code == 0, result.output
    assert "poses.csv" in result.output and "detections.csv" in result.output
    session = load_session(out / "session.json")
    truth = json.loads((out / "truth.json").read_text())
    assert truth["frames"]["time_offset_s"] == 0.25 and truth["frames"]["frame_rate_hz"] == 4.0
    T_true = np.array([v["T_base_optical_true"] for v in truth["views"]])
    assert_allclose(session.views[0].T_base_optical, T_true[1], atol=1e-9)  # one frame late: the next view's pose
    imported = tmp_path / "imported.json"
    res = runner.invoke(
        app,
        ["import", "--camera", str(out / "session.json"), "--poses", str(out / "poses.csv")]
        + ["--detections", str(out / "detections.csv"), "-o", str(imported)],
    )
    assert res.exit_code == 0, res.output
    again = load_session(imported)
    for a, b in zip(session.views, again.views):
        assert_allclose(b.T_base_optical, a.T_base_optical, atol=1e-6)
        assert_allclose(b.boxes_xyxy, a.boxes_xyxy, atol=1e-9)


def test_simulate_time_offset_needs_views_along_a_path(tmp_path):
    res = runner.invoke(app, ["simulate", "--views", "ring:4", "--time-offset", "0.1", "-o", str(tmp_path / "x")])
    assert res.exit_code == 2 and "--time-offset: needs views along a path" in res.stderr
    res = runner.invoke(
        app, ["simulate", "--views", "row:4", "--time-offset", "0.1", "--frame-rate", "0", "-o", str(tmp_path / "y")]
    )
    assert res.exit_code == 2 and "--frame-rate" in res.stderr
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()
