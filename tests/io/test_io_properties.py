"""Property tests: malformed and extreme inputs to every reader end in a valid session or an InputError.

Inputs are the real-format fixtures with random edits (tokens replaced by NaN, huge
numbers, text; lines deleted, duplicated, truncated; random text inserted), random
JSON structures, corrupted ROS bags and odd Ultralytics results. Warnings other
than InputWarning count as failures (see ``conftest.outcome``).
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

import io_scene as scene
import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from conftest import FIXTURES, outcome
from monovisual3d import Camera
from monovisual3d.io import (
    ImageDetections,
    build_session,
    image_detections_from_result,
    import_session,
    read_bag,
    read_calibration,
    read_coco,
    read_hand_eye,
    read_pose_json,
    read_poses,
)
from monovisual3d.session import Session
from monovisual3d.session.load import session_from_dict

#: Examples per property; raise for a deeper local run, e.g. MV3D_HYPOTHESIS_EXAMPLES=1000.
EXAMPLES = int(os.environ.get("MV3D_HYPOTHESIS_EXAMPLES", "40"))
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow])

TOKENS = [
    "nan",
    "NaN",
    "inf",
    "-inf",
    ".inf",
    "1e308",
    "-1e308",
    "1e999",
    "1e-320",
    "0",
    "-0",
    "-1",
    "0.0",
    "abc",
    "",
    "[]",
    "{}",
    "null",
    "~",
    "true",
    "1.5",
    "2",
    "99999999999999999999999",
    ":",
    "- x",
    "#",
    "0x10",
    "1_000",
    '"',
    "[1, 2]",
    "{a: 1}",
    "!!opencv-matrix",
    "!!python/object",
    "&a",
    "*a",
]
SPLIT = re.compile(r"(\s+|,|\[|\]|:|\{|\})")


@st.composite
def mutated(draw: Any, text: str) -> str:
    """``text`` with 1-4 random edits."""
    lines = text.splitlines() or [""]
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["token", "token", "token", "delete", "duplicate", "truncate", "insert"]))
        if not lines:
            lines = [""]
        i = draw(st.integers(0, len(lines) - 1))
        if op == "token":
            parts = SPLIT.split(lines[i])
            idx = [k for k, t in enumerate(parts) if t and not SPLIT.fullmatch(t)]
            if idx:
                k = draw(st.sampled_from(idx))
                parts[k] = draw(st.one_of(st.sampled_from(TOKENS), st.text(max_size=8)))
                lines[i] = "".join(parts)
        elif op == "delete":
            del lines[i]
        elif op == "duplicate":
            lines.insert(i, lines[i])
        elif op == "truncate":
            lines[i] = lines[i][: draw(st.integers(0, len(lines[i])))]
        else:
            lines.insert(i, draw(st.text(max_size=30)))
    return "\n".join(lines) + "\n"


def fixture_text(name: str) -> str:
    return (FIXTURES / name).read_text()


JSON = st.recursive(
    st.one_of(
        st.none(),
        st.booleans(),
        st.integers(-(2**70), 2**70),
        st.floats(allow_nan=True, allow_infinity=True),
        st.text(max_size=10),
    ),
    lambda children: st.one_of(st.lists(children, max_size=5), st.dictionaries(st.text(max_size=12), children, max_size=5)),
    max_leaves=25,
)


def session_from_camera(camera: Camera) -> Session:
    """The calibration must be usable: a one-view session with a box inside the image."""
    w, h = camera.size
    data = {
        "camera": camera.to_dict(),
        "views": [{"pose": {"matrix": np.eye(4).tolist()}, "detections": [{"bbox_xyxy": [0.0, 0.0, w / 2, h / 2]}]}],
    }
    return session_from_dict(data)


def check(status_value: tuple[str, Any], kind: type | None = None) -> None:
    status, value = status_value
    assert status in ("ok", "input_error")
    event(status)
    if status == "ok" and kind is not None:
        assert isinstance(value, kind)


# ---------------------------------------------------------------------- calibrations
CALIBRATIONS = [
    ("kalibr_camchain.yaml", {"camera_name": "cam0"}),
    ("kalibr_camchain.yaml", {"camera_name": "cam1"}),
    ("ros_camera_info.yaml", {}),
    ("opencv_calibration.yaml", {}),
    ("opencv_rational.json", {}),
    ("opencv_fisheye.yaml", {"distortion_model": "fisheye"}),
    ("depthai_oak1.json", {"image_size": (640, 480)}),
]


@SETTINGS
@given(st.sampled_from(CALIBRATIONS), st.data())
def test_calibration_files(case, data):
    name, options = case
    text = data.draw(mutated(fixture_text(name)))
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / name
        path.write_text(text, encoding="utf-8")
        check(outcome(lambda: session_from_camera(read_calibration(path, **options))), Session)


@SETTINGS
@given(JSON, st.sampled_from([None, "kalibr", "ros", "opencv", "depthai", "monovisual3d"]))
def test_calibration_structures(data, fmt):
    if isinstance(data, str):  # a string is a file name for read_calibration
        data = [data]
    check(outcome(lambda: session_from_camera(read_calibration({"cam0": data} if fmt == "kalibr" else data, format=fmt))))
    if isinstance(data, dict):
        for key in ("camera_matrix", "cameraData", "K"):
            check(outcome(lambda key=key: session_from_camera(read_calibration({**data, key: data}))))


# ---------------------------------------------------------------------- detections, through the whole import
DETECTIONS = [
    "yolo_labels/img_000.txt",
    "yolo_labels/img_002.txt",
    "coco_results.json",
    "coco_annotations.json",
    "detections.csv",
]


@SETTINGS
@given(st.sampled_from(DETECTIONS), st.data())
def test_detection_files_import(name, data):
    text = data.draw(mutated(fixture_text(name)))
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        shutil.copytree(FIXTURES / "yolo_labels", d / "yolo_labels")
        shutil.copy(FIXTURES / "coco_annotations.json", d / "coco_annotations.json")
        (d / name).write_text(text, encoding="utf-8")
        target = d / ("yolo_labels" if name.startswith("yolo") else name)
        images = d / "coco_annotations.json" if name == "coco_results.json" else None

        def run() -> Session:
            return import_session(FIXTURES / "ros_camera_info.yaml", FIXTURES / "poses.csv", target, coco_images=images).session

        check(outcome(run), Session)


@SETTINGS
@given(JSON)
def test_coco_structures(data):
    if isinstance(data, str):  # a string is a file name for read_coco
        data = [data]
    traj = read_poses(FIXTURES / "poses.csv")
    camera = read_calibration(FIXTURES / "ros_camera_info.yaml")
    check(outcome(lambda: build_session(camera, traj, read_coco(data)).session))
    check(outcome(lambda: build_session(camera, traj, read_coco({"images": data, "annotations": []})).session))


# ---------------------------------------------------------------------- poses
POSES = [("poses_tum.txt", {}), ("poses.csv", {}), ("poses_ur.csv", {"units": "mm"}), ("poses.json", {})]


@SETTINGS
@given(st.sampled_from(POSES), st.data(), st.sampled_from(["auto", "stamp", "order"]), st.floats(0, 2))
def test_pose_files_import(case, data, match, max_gap):
    name, options = case
    text = data.draw(mutated(fixture_text(name)))
    camera = read_calibration(FIXTURES / "ros_camera_info.yaml")
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / name
        path.write_text(text, encoding="utf-8")
        status, traj = outcome(lambda: read_poses(path, **options))
        event(f"read {status}")
        if status != "ok":
            return
        frames = [ImageDetections(f"img_{i:03d}.png", stamp=1_700_000_000.0 + 0.5 * i) for i in range(len(traj))]
        check(outcome(lambda: build_session(camera, traj, frames, match=match, max_gap=max_gap).session), Session)


@SETTINGS
@given(JSON, st.sampled_from(["m", "mm", "cm", "km"]))
def test_pose_and_hand_eye_structures(data, units):
    if isinstance(data, str):  # a string is a file name for these readers
        data = [data]
    check(outcome(lambda: read_pose_json(data, units=units)))
    check(outcome(lambda: read_hand_eye(data, units=units)))
    check(outcome(lambda: read_hand_eye({"transformation": data})))


@SETTINGS
@given(st.sampled_from(["hand_eye_easy_handeye.yaml", "hand_eye_opencv.json"]), st.data())
def test_hand_eye_files(name, data):
    text = data.draw(mutated(fixture_text(name)))
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / name
        path.write_text(text, encoding="utf-8")
        status, T = outcome(lambda: read_hand_eye(path))
        event(status)
        if status == "ok":
            assert T.shape == (4, 4) and np.all(np.isfinite(T))


# ---------------------------------------------------------------------- ROS bags
@pytest.fixture(scope="module")
def valid_bag_bytes() -> bytes:
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "scene.bag"
        scene.write_scene_bag(path, "ros1")
        return path.read_bytes()


@settings(
    max_examples=max(EXAMPLES // 2, 10),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(st.data())
def test_corrupted_ros1_bags(valid_bag_bytes, data):
    raw = bytearray(valid_bag_bytes)
    op = data.draw(st.sampled_from(["flip", "truncate", "zero"]))
    if op == "truncate":
        raw = raw[: data.draw(st.integers(0, len(raw) - 1))]
    else:
        for _ in range(data.draw(st.integers(1, 8))):
            i = data.draw(st.integers(0, len(raw) - 1))
            raw[i] = data.draw(st.integers(0, 255)) if op == "flip" else 0
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "corrupt.bag"
        path.write_bytes(bytes(raw))

        def run() -> Session:
            options = {"base_frame": "base_link", "camera_frame": "camera_optical_frame", "labels": ["tomato"]}
            return read_bag(path, class_names=["tomato", "leaf"], **options).session

        check(outcome(run), Session)


# ---------------------------------------------------------------------- Ultralytics results
class _Boxes:
    def __init__(self, xyxy, conf, cls):
        self.xyxy, self.conf, self.cls = xyxy, conf, cls


class _Result:
    def __init__(self, boxes, shape, masks=None):
        self.boxes, self.orig_shape, self.masks, self.names, self.path = boxes, shape, masks, {0: "tomato"}, "x.png"


FLOATS = st.one_of(st.floats(0, 700, width=32), st.floats(allow_nan=True, allow_infinity=True, width=32))


@SETTINGS
@given(
    st.integers(0, 4).flatmap(
        lambda n: st.tuples(
            st.lists(st.lists(FLOATS, min_size=4, max_size=4), min_size=n, max_size=n),
            st.lists(FLOATS, min_size=n, max_size=n),
            st.lists(FLOATS, min_size=n, max_size=n),
        )
    ),
    st.one_of(st.tuples(st.integers(-2, 2000), st.integers(-2, 2000)), st.none(), st.just("abc")),
)
def test_ultralytics_results(arrays, shape):
    xyxy, conf, cls = arrays
    result = _Result(_Boxes(np.array(xyxy, dtype=np.float32).reshape(-1, 4), np.array(conf), np.array(cls)), shape)
    status, frame = outcome(lambda: image_detections_from_result(result))
    event(f"convert {status}")
    if status == "ok":
        camera = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
        traj = read_poses(FIXTURES / "poses.json")
        check(outcome(lambda: build_session(camera, traj, [frame, frame], match="order").session), Session)
