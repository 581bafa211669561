"""ROS bags written with rosbags' own writers (ROS 1, ROS 2 sqlite3, ROS 2 MCAP) import to the same estimates."""

from __future__ import annotations

import io_scene as scene
import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from monovisual3d import load_session
from monovisual3d.cli import app
from monovisual3d.errors import InputError, InputWarning
from monovisual3d.io import read_bag

pytest.importorskip("rosbags")

BAG_KINDS = ("ros1", "sqlite3", "mcap")


def bag_path(tmp_path, kind: str):
    return tmp_path / ("scene.bag" if kind == "ros1" else f"scene_{kind}")


def import_bag(path, **kw):
    options = {"base_frame": "base_link", "camera_frame": "camera_optical_frame", "detections_topic": "/detections"}
    options.update(labels=["tomato"], class_names=["tomato", "leaf"])
    options.update(kw)
    with pytest.warns(InputWarning) as record:
        result = read_bag(path, **options)
    return result, [str(w.message) for w in record]


@pytest.fixture(scope="module")
def reference_positions() -> np.ndarray:
    return scene.localize_positions(scene.bag_reference_session_dict())


@pytest.mark.parametrize("kind", BAG_KINDS)
def test_bag_round_trip(tmp_path, kind, reference_positions):
    path = bag_path(tmp_path, kind)
    scene.write_scene_bag(path, kind)
    result, warned = import_bag(path)
    ref = scene.bag_reference_session_dict()
    session = result.session
    assert session.camera == scene.CAMERA
    assert len(session.views) == 4
    for v, r in zip(session.views, ref["views"]):
        assert_allclose(v.T_base_optical, np.array(r["pose"]["matrix"]), atol=1e-9)  # TF chain + interpolation
        assert_allclose(v.boxes_xyxy, [d["bbox_xyxy"] for d in r["detections"]], atol=1e-9)
        assert [d.label for d in v.detections] == ["tomato"] * 3
        assert v.stamp == pytest.approx(r["stamp"], abs=1e-6)
    # the image taken 5 s after the last transform is skipped, with a warning and in the summary
    assert any("skipped view stamp 1700000008.030000: transform not available within max_gap 0.1 s" in m for m in warned)
    assert result.summary.reasons() == {
        ("detection", "label not in ['tomato']"): 4,
        ("view", "transform not available within max_gap 0.1 s"): 1,
    }
    assert_allclose(scene.localize_positions(session), reference_positions, atol=1e-6)


def test_bag_without_vision_msgs_definitions(tmp_path):
    path = bag_path(tmp_path, "sqlite3")
    scene.write_scene_bag(path, "sqlite3", drop_vision_definitions=True)
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:  # the bag really lacks them
        assert "vision_msgs/msg/Detection2DArray" not in reader.typestore.fielddefs
    result, _ = import_bag(path, base_frame="/world")
    ref = scene.bag_reference_session_dict()
    for v, r in zip(result.session.views, ref["views"]):
        assert_allclose(v.T_base_optical, scene.T_world_base() @ np.array(r["pose"]["matrix"]), atol=1e-9)
        assert_allclose(v.boxes_xyxy, [d["bbox_xyxy"] for d in r["detections"]], atol=1e-9)


def test_bag_errors(tmp_path):
    path = bag_path(tmp_path, "ros1")
    scene.write_scene_bag(path, "ros1")
    with pytest.raises(InputError, match=r"no topic '/yolo'; Detection2DArray topics in the bag: \['/detections'\]"):
        read_bag(path, base_frame="base_link", camera_frame="camera_optical_frame", detections_topic="/yolo")
    with pytest.raises(InputError, match="carries tf2_msgs/msg/TFMessage, expected vision_msgs/Detection2DArray"):
        read_bag(path, base_frame="base_link", camera_frame="camera_optical_frame", detections_topic="/tf")
    with pytest.raises(InputError, match=r"camera frame 'camera' is not in the transforms; frames seen: \['base_link', "):
        read_bag(path, base_frame="base_link", camera_frame="camera", detections_topic="/detections")
    with pytest.raises(InputError, match=r"no topic '/info'; CameraInfo topics in the bag: \['/camera/camera_info'\]"):
        read_bag(path, base_frame="base_link", camera_frame="camera_optical_frame", camera_info_topic="/info")
    (tmp_path / "junk.bag").write_bytes(b"#ROSBAG V2.0\n" + bytes(range(256)) * 4)
    with pytest.raises(InputError, match="junk.bag: cannot open the bag"):
        read_bag(tmp_path / "junk.bag", base_frame="a", camera_frame="b")
    (tmp_path / "notes.txt").write_text("not a bag")
    with pytest.raises(InputError, match="notes.txt: expected a ROS 1 .bag file or a ROS 2 bag folder"):
        read_bag(tmp_path / "notes.txt", base_frame="a", camera_frame="b")
    with pytest.raises(InputError, match="missing.bag: bag not found"):
        read_bag(tmp_path / "missing.bag", base_frame="a", camera_frame="b")


def test_cli_import_bag(tmp_path):
    path = bag_path(tmp_path, "mcap")
    scene.write_scene_bag(path, "mcap")
    out = tmp_path / "session.json"
    args = ["import-bag", str(path), "--base-frame", "base_link", "--camera-frame", "camera_optical_frame"]
    args += ["--detections", "/detections", "--camera-info", "/camera/camera_info", "--label", "tomato", "--output", str(out)]
    with pytest.warns(InputWarning, match="skipped view stamp 1700000008.030000"):
        res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    assert "views: 4 (0 without detections)" in res.output
    assert "skipped 1 view: transform not available within max_gap 0.1 s" in res.output
    session = load_session(out)
    assert len(session.views) == 4 and all(len(v.detections) == 3 for v in session.views)
