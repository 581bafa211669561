"""import_session / build_session: files of a simulated scene round-trip to the same estimates."""

from __future__ import annotations

import json

import io_scene as scene
import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from monovisual3d import load_session
from monovisual3d.cli import app
from monovisual3d.errors import InputError, InputWarning
from monovisual3d.frames import T_cameralink_optical, invert_transform
from monovisual3d.io import ImageDetections, build_session, import_session, read_poses
from monovisual3d.session import Detection


@pytest.fixture(scope="module")
def reference_positions() -> np.ndarray:
    return scene.localize_positions(scene.direct_session())


def assert_same_views(session, reference: dict) -> None:
    assert len(session.views) == len(reference["views"])
    for v, r in zip(session.views, reference["views"]):
        assert_allclose(v.T_base_optical, np.array(r["pose"]["matrix"]), atol=1e-9)
        assert_allclose(v.boxes_xyxy, [d["bbox_xyxy"] for d in r["detections"]], atol=1e-6)
        assert [d.score for d in v.detections] == [d["score"] for d in r["detections"]]


def test_camera_info_csv_yolo_round_trip(tmp_path, reference_positions):
    poses = scene.camera_poses()
    scene.write_camera_info_yaml(tmp_path / "camera.yaml")
    scene.write_pose_csv(tmp_path / "poses.csv", poses)
    scene.write_yolo_labels(tmp_path / "labels", poses)
    result = import_session(tmp_path / "camera.yaml", tmp_path / "poses.csv", tmp_path / "labels")
    assert result.session.camera == scene.CAMERA
    assert_same_views(result.session, scene.direct_session_dict())
    assert [v.image for v in result.session.views] == [f"img_{i:03d}.png" for i in range(4)]
    assert result.summary.skipped == []
    assert "matched poses to detections by file name" in result.summary.notes
    assert_allclose(scene.localize_positions(result.session), reference_positions, atol=1e-6)


def test_tum_and_stamped_labels_match_by_time(tmp_path, reference_positions):
    poses = scene.camera_poses()
    stamps = [scene.T0 + i for i in range(4)]
    scene.write_camera_info_yaml(tmp_path / "camera.yaml")
    scene.write_tum(tmp_path / "poses.txt", poses, stamps)
    scene.write_yolo_labels(tmp_path / "labels", poses, names=[f"{t:.6f}" for t in stamps])
    result = import_session(tmp_path / "camera.yaml", tmp_path / "poses.txt", tmp_path / "labels")
    assert "matched poses to detections by time stamp" in result.summary.notes
    assert_allclose([v.stamp for v in result.session.views], stamps)
    assert_same_views(result.session, scene.direct_session_dict())
    assert_allclose(scene.localize_positions(result.session), reference_positions, atol=1e-6)


def test_eye_in_hand_in_millimetres_with_camera_link_hand_eye(tmp_path, reference_positions):
    """End-effector poses (UR-style: mm + rotation vector) and a camera_link hand-eye give the same session."""
    X = scene.T_tool0_cameralink()  # T_ee_cameralink
    ee = [T @ invert_transform(T_cameralink_optical()) @ invert_transform(X) for T in scene.camera_poses()]
    scene.write_pose_csv(tmp_path / "ee.csv", ee, units=1e-3, rotvec=True)
    p, q = X[:3, 3], scene.quaternion_xyzw(X)
    (tmp_path / "hand_eye.yaml").write_text(
        "eye_on_hand: true\ntransformation:\n"
        + "".join(f"  {k}: {float(v)!r}\n" for k, v in zip(("x", "y", "z", "qx", "qy", "qz", "qw"), [*p, *q]))
    )
    scene.write_camera_info_yaml(tmp_path / "camera.yaml")
    scene.write_yolo_labels(tmp_path / "labels", scene.camera_poses())
    result = import_session(
        tmp_path / "camera.yaml",
        tmp_path / "ee.csv",
        tmp_path / "labels",
        hand_eye=tmp_path / "hand_eye.yaml",
        units="mm",
        pose_frame="camera_link",
    )
    assert_same_views(result.session, scene.direct_session_dict())
    assert_allclose(scene.localize_positions(result.session), reference_positions, atol=1e-6)


def test_skipped_items_are_reported(tmp_path):
    poses = scene.camera_poses()
    scene.write_camera_info_yaml(tmp_path / "camera.yaml")
    scene.write_pose_csv(tmp_path / "poses.csv", poses[:3])  # no pose for img_003
    scene.write_yolo_labels(tmp_path / "labels", poses)
    (tmp_path / "labels" / "img_000.txt").unlink()  # YOLO writes no file for an image without detections
    with pytest.warns(InputWarning) as record:
        result = import_session(tmp_path / "camera.yaml", tmp_path / "poses.csv", tmp_path / "labels", min_score=0.8)
    messages = [str(w.message) for w in record]
    assert any("skipped image img_003: no pose for this image (2 detections)" in m for m in messages)
    assert any("views[0]: no detections" in m for m in messages)
    s = result.summary
    assert (s.n_views, s.n_empty_views, s.n_detections) == (3, 1, 4)
    assert s.reasons() == {("image", "no pose for this image"): 1, ("detection", "score below 0.8"): 3}
    lines = s.lines()
    assert lines[0] == "views: 3 (1 without detections)"
    assert "skipped 3 detections: score below 0.8 [img_001 #2, img_002 #2, img_003 #2]" in lines


def test_stamp_gaps_reject_views_with_a_reason(tmp_path):
    poses = scene.camera_poses()
    stamps = [scene.T0 + i for i in range(4)]
    scene.write_camera_info_yaml(tmp_path / "camera.yaml")
    scene.write_tum(tmp_path / "poses.txt", poses[:2], stamps[:2])
    scene.write_yolo_labels(tmp_path / "labels", poses, names=[f"{t + 0.05:.6f}" for t in stamps])
    with pytest.warns(InputWarning) as record:
        result = import_session(tmp_path / "camera.yaml", tmp_path / "poses.txt", tmp_path / "labels")
    messages = [str(w.message).split(": ", 1)[1] for w in record]
    assert messages == [
        "skipped view 1700000002.050000: no pose within max_gap 0.1 s (1.05 s after the last pose, more than max_gap 0.1 s)",
        "skipped view 1700000003.050000: no pose within max_gap 0.1 s (2.05 s after the last pose, more than max_gap 0.1 s)",
    ]
    assert len(result.session.views) == 2
    assert result.summary.reasons() == {("view", "no pose within max_gap 0.1 s"): 2}


def test_build_session_errors(tmp_path):
    traj = read_poses(scene_pose_file(tmp_path))
    frames = [ImageDetections("img_000.png", detections=(Detection(np.array([700.0, 10, 720, 30])),), source="d.csv")]
    with pytest.raises(InputError, match=r"d.csv: image img_000.png, detection 0: box .* lies outside the 640x480 image"):
        build_session(scene.CAMERA, traj, frames)
    frames = [ImageDetections("img_000.png", image_size=(1280, 960), source="r.json")]
    with pytest.raises(
        InputError,
        match=r"r.json: image img_000.png is 1280x960 but the calibration is 640x480: "
        r"pass --image-size 1280x960 \(image_size=\(1280, 960\)\)",
    ):
        build_session(scene.CAMERA, traj, frames)
    with pytest.raises(InputError, match=r"p.json: --match stamp \(match='stamp'\): the poses have no time stamps"):
        build_session(scene.CAMERA, read_poses(tmp_path / "p.json"), [ImageDetections(None, 1.0)], match="stamp")
    with pytest.raises(
        InputError, match=r"poses.csv: --match order \(match='order'\): 4 poses but 1 images in the detections \(a.txt\)"
    ):
        build_session(scene.CAMERA, traj, [ImageDetections("a.png", source="a.txt")], match="order")


def scene_pose_file(tmp_path):
    scene.write_pose_csv(tmp_path / "poses.csv", scene.camera_poses())
    (tmp_path / "p.json").write_text(json.dumps([T.tolist() for T in scene.camera_poses()]))
    return tmp_path / "poses.csv"


def test_cli_import_writes_a_valid_session_and_a_summary(tmp_path):
    poses = scene.camera_poses()
    scene.write_camera_info_yaml(tmp_path / "camera.yaml")
    scene.write_pose_csv(tmp_path / "poses.csv", poses)
    scene.write_yolo_labels(tmp_path / "labels", poses)
    out = tmp_path / "session.json"
    args = ["import", "--camera", str(tmp_path / "camera.yaml"), "--poses", str(tmp_path / "poses.csv")]
    args += ["--detections", str(tmp_path / "labels"), "--label", "tomato", "--min-score", "0.8", "--output", str(out)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    assert "views: 4 (0 without detections)" in res.output
    assert "skipped 4 detections: score below 0.8" in res.output
    session = load_session(out)
    assert sum(len(v.detections) for v in session.views) == 8


def test_cli_import_reports_errors_in_one_line(tmp_path):
    scene.write_camera_info_yaml(tmp_path / "camera.yaml")
    (tmp_path / "poses.txt").write_text("1 0 0 0 0 0 0\n")
    (tmp_path / "d.csv").write_text("image,x1,y1,x2,y2\n")
    args = ["import", "--camera", str(tmp_path / "camera.yaml"), "--poses", str(tmp_path / "poses.txt")]
    res = CliRunner().invoke(app, args + ["--detections", str(tmp_path / "d.csv"), "-o", str(tmp_path / "s.json")])
    assert res.exit_code == 2
    assert "poses.txt: line 1: 7 values, expected 8" in res.output
    assert "Traceback" not in res.output
    assert not (tmp_path / "s.json").exists()


def test_csv_boxes_of_smaller_images_stop_the_import(fixtures, tmp_path):
    """Boxes in 640x480 pixels against the OAK's 4056x3040 calibration: the import stops and names --image-size."""
    args = ["import", "--camera", str(fixtures / "depthai_oak1.json"), "--poses", str(fixtures / "poses.csv")]
    args += ["--detections", str(fixtures / "detections.csv"), "-o", str(tmp_path / "s.json")]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2, res.output
    message = res.stderr.strip().splitlines()[-1]
    assert message.startswith(f"error: {fixtures / 'detections.csv'}: all 3 boxes lie within x <= 413, y <= 270 px")
    assert "4056x3040 calibration image" in message and "--image-size WxH" in message
    assert not (tmp_path / "s.json").exists()
    # stated: the camera is scaled to the detector's images and the boxes stay as they are
    with pytest.warns(InputWarning, match=r"views\[2\]: no detections"):  # img_002 has none in the fixture
        res = CliRunner().invoke(app, [*args, "--image-size", "640x480"])
        assert res.exit_code == 0, res.output
        session = load_session(tmp_path / "s.json")
    assert session.camera.size == (640, 480)
    assert_allclose(session.views[0].boxes_xyxy[0], [288, 210, 352, 270])
    # boxes that really are in calibration pixels are accepted once the size is stated
    with pytest.warns(InputWarning, match=r"views\[2\]: no detections"):
        res = CliRunner().invoke(app, [*args, "--image-size", "4056x3040"])
        assert res.exit_code == 0, res.output
        assert load_session(tmp_path / "s.json").camera.size == (4056, 3040)


def test_box_extent_check_applies_to_given_frames_without_a_size(fixtures):
    frames = [ImageDetections(f"img_00{i}.png", detections=(Detection(np.array([100.0, 80, 140, 120])),)) for i in range(3)]
    with pytest.raises(InputError, match=r"all 3 boxes lie within x <= 140, y <= 120 px.*--image-size WxH"):
        import_session(fixtures / "depthai_oak1.json", fixtures / "poses.csv", frames)
    result = import_session(fixtures / "depthai_oak1.json", fixtures / "poses.csv", frames, image_size=(640, 480))
    assert result.session.camera.size == (640, 480)


def test_yolo_summary_says_which_size_the_boxes_were_scaled_to(tmp_path):
    poses = scene.camera_poses()
    scene.write_camera_info_yaml(tmp_path / "camera.yaml")
    scene.write_pose_csv(tmp_path / "poses.csv", poses)
    scene.write_yolo_labels(tmp_path / "labels", poses)
    result = import_session(tmp_path / "camera.yaml", tmp_path / "poses.csv", tmp_path / "labels")
    assert any(
        n.startswith("YOLO boxes are normalised: scaled to 640x480 pixels, the calibration's image size")
        for n in result.summary.notes
    )
    result = import_session(tmp_path / "camera.yaml", tmp_path / "poses.csv", tmp_path / "labels", image_size=(320, 240))
    assert "YOLO boxes are normalised: scaled to 320x240 pixels, the size given by --image-size" in result.summary.notes


def test_tum_poses_with_yolo_labels_named_by_frame_need_match_order(tmp_path, reference_positions):
    poses = scene.camera_poses()
    scene.write_camera_info_yaml(tmp_path / "camera.yaml")
    scene.write_tum(tmp_path / "poses.txt", poses, [scene.T0 + i for i in range(4)])
    scene.write_yolo_labels(tmp_path / "labels", poses)  # img_000.txt ...: names, no stamps
    with pytest.raises(InputError) as err:
        import_session(tmp_path / "camera.yaml", tmp_path / "poses.txt", tmp_path / "labels")
    message = str(err.value)
    assert f"cannot match the poses ({tmp_path / 'poses.txt'}: stamps, no image names)" in message
    assert f"to the detections ({tmp_path / 'labels'}: image names, no stamps)" in message
    assert message.endswith("pass --match order (match='order')")
    result = import_session(tmp_path / "camera.yaml", tmp_path / "poses.txt", tmp_path / "labels", match="order")
    assert "paired poses and images in order (--match order): pose 0 with img_000, ..., pose 3 with img_003" in (
        result.summary.notes
    )
    assert_same_views(result.session, scene.direct_session_dict())


def test_cli_errors_name_the_file_and_the_options(fixtures, tmp_path):
    args = ["import", "--camera", str(fixtures / "depthai_oak1.json"), "--poses", str(fixtures / "poses.csv")]
    args += ["--detections", str(fixtures / "detections.csv"), "-o", str(tmp_path / "s.json")]
    res = CliRunner().invoke(app, [*args, "--image-size", "1920x1080"])
    assert res.exit_code == 2
    assert f"error: {fixtures / 'depthai_oak1.json'}: --image-size (image_size): the detections' 1920x1080" in res.stderr
    assert "--resize stretch or --resize crop" in res.stderr and "--crop X1,Y1,X2,Y2" in res.stderr
    args[4] = str(fixtures / "poses_tum.txt")
    res = CliRunner().invoke(app, [*args, "--image-size", "640x480", "--match", "order"])
    assert res.exit_code == 2
    assert f"{fixtures / 'poses_tum.txt'}: --match order (match='order'): 4 poses but" in res.stderr
    res = CliRunner().invoke(app, [*args, "--image-size", "640x480", "--max-gap", "-1"])
    assert res.exit_code == 2
    assert "--max-gap (max_gap): got -1.0" in res.stderr
