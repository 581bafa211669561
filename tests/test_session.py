"""Session loading: valid inputs, every bad-input branch, warnings, file names in messages."""

from __future__ import annotations

import copy
import json
import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose

from monovisual3d import Camera, InputError, InputWarning, Session, load_session
from monovisual3d.examples import example_session_path
from monovisual3d.frames import T_base_optical_from_T_base_cameralink, transform_from_position_quaternion

DELETE = object()
NAN, INF = float("nan"), float("inf")
VALID_VIEW = {
    "pose": {"position": [0.0, 0.0, 0.0], "quaternion_xyzw": [0.0, 0.0, 0.0, 1.0]},
    "detections": [{"bbox_xyxy": [300.0, 220.0, 340.0, 260.0]}],
}
ROT_X_90 = [[1.0, 0.0, 0.0, 0.1], [0.0, 0.0, -1.0, 0.2], [0.0, 1.0, 0.0, 0.3], [0.0, 0.0, 0.0, 1.0]]


def edit(data: dict[str, Any], path: str, value: Any) -> dict[str, Any]:
    """Set (or with DELETE remove) ``data[path]``; ``path`` is slash separated, list indices as numbers."""
    *parents, last = path.split("/")
    node: Any = data
    for key in parents:
        node = node[int(key)] if isinstance(node, list) else node[key]
    key: Any = int(last) if isinstance(node, list) else last
    if value is DELETE:
        del node[key]
    else:
        node[key] = value
    return data


def with_edits(valid: dict[str, Any], *edits: tuple[str, Any]) -> dict[str, Any]:
    data = copy.deepcopy(valid)
    for path, value in edits:
        edit(data, path, value)
    return data


def write(tmp_path: Path, data: Any, suffix: str) -> Path:
    path = tmp_path / f"session{suffix}"
    if suffix == ".json":
        path.write_text(json.dumps(data))  # NaN/inf become JSON's NaN/Infinity extensions
    else:
        path.write_text(yaml.safe_dump(data))
    return path


# ---------------------------------------------------------------------- valid input
def test_valid_session_loads(valid_session: dict[str, Any]) -> None:
    s = load_session(valid_session)
    assert isinstance(s, Session)
    assert s.camera == Camera(640, 480, 462.4, 462.4, 320.0, 240.0)
    assert len(s.views) == 1 and s.workspace is None and s.source is None
    view = s.views[0]
    assert_allclose(view.T_base_optical, np.eye(4))
    assert_allclose(view.boxes_xyxy, [[300.0, 220.0, 340.0, 260.0]])
    det = view.detections[0]
    assert (det.score, det.label, det.mask) == (0.9, "tomato", None)


def test_hfov_camera_and_distortion(valid_session: dict[str, Any]) -> None:
    cam = {"width": 640, "height": 480, "hfov_deg": 90.0, "distortion": {"model": "radtan", "coefficients": [0.1, 0, 0, 0]}}
    s = load_session(with_edits(valid_session, ("camera", cam)))
    assert_allclose([s.camera.fx, s.camera.cx, s.camera.cy], [320.0, 320.0, 240.0])
    assert s.camera.distortion_model == "plumb_bob"
    assert s.camera.distortion_coefficients == (0.1, 0.0, 0.0, 0.0)


def test_matrix_pose(valid_session: dict[str, Any]) -> None:
    s = load_session(with_edits(valid_session, ("views/0/pose", {"matrix": ROT_X_90})))
    assert_allclose(s.views[0].T_base_optical, ROT_X_90)


def test_camera_link_pose_frame_is_converted(valid_session: dict[str, Any], rng: np.random.Generator) -> None:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    data = with_edits(valid_session, ("pose_frame", "camera_link"), ("views/0/pose/quaternion_xyzw", q.tolist()))
    T_base_link = transform_from_position_quaternion([0, 0, 0], q)
    assert_allclose(load_session(data).views[0].T_base_optical, T_base_optical_from_T_base_cameralink(T_base_link), atol=1e-12)
    # a matrix pose is converted too
    data = with_edits(valid_session, ("pose_frame", "camera_link"), ("views/0/pose", {"matrix": ROT_X_90}))
    assert_allclose(load_session(data).views[0].T_base_optical, T_base_optical_from_T_base_cameralink(ROT_X_90), atol=1e-12)


def test_quaternion_within_tolerance_is_normalised(valid_session: dict[str, Any]) -> None:
    s = load_session(with_edits(valid_session, ("views/0/pose/quaternion_xyzw", [0.0, 0.0, 0.0, 1.0004])))
    assert_allclose(s.views[0].T_base_optical, np.eye(4), atol=1e-12)


def test_workspace_and_optional_fields(valid_session: dict[str, Any]) -> None:
    data = with_edits(
        valid_session,
        ("workspace", {"min": [0.2, -0.3, 0.0], "max": [1.0, 0.3, 0.8]}),
        ("views/0/stamp", 12.5),
        ("views/0/image", "frame_0001.png"),
        ("views/0/detections/0/mask", {"polygon": [[300, 220], [340, 220], [320, 260]]}),
        ("metadata", {"robot": "anything goes here"}),
    )
    s = load_session(data)
    assert_allclose(s.workspace.min, [0.2, -0.3, 0.0])
    assert_allclose(s.workspace.max, [1.0, 0.3, 0.8])
    assert (s.views[0].stamp, s.views[0].image) == (12.5, "frame_0001.png")
    assert s.views[0].detections[0].mask == {"polygon": [[300, 220], [340, 220], [320, 260]]}


def test_numpy_values_are_accepted(valid_session: dict[str, Any]) -> None:
    """A dict built in Python may hold numpy scalars and arrays."""
    data = with_edits(
        valid_session,
        ("camera/width", np.int64(640)),
        ("camera/fx", np.float32(462.5)),
        ("views/0/pose/position", np.array([0.1, 0.2, 0.3])),
        ("views/0/detections/0/bbox_xyxy", np.array([300.0, 220.0, 340.0, 260.0])),
    )
    s = load_session(data)
    assert s.camera.width == 640 and s.camera.fx == 462.5
    assert_allclose(s.views[0].T_base_optical[:3, 3], [0.1, 0.2, 0.3])


@pytest.mark.parametrize("suffix", [".json", ".yaml", ".yml"])
def test_json_and_yaml_files_load_the_same(valid_session: dict[str, Any], tmp_path: Path, suffix: str) -> None:
    path = write(tmp_path, valid_session, suffix)
    s = load_session(path)
    assert s == load_session(valid_session)
    assert s.source == str(path)
    assert load_session(str(path)) == s


def test_session_round_trips_through_json(tmp_path: Path) -> None:
    s = load_session(example_session_path())
    out = tmp_path / "copy.json"
    text = s.to_json(out)
    assert json.loads(out.read_text()) == json.loads(text)
    s2 = load_session(out)
    assert s2.camera == s.camera
    for a, b in zip(s2.views, s.views, strict=True):
        assert_allclose(a.T_base_optical, b.T_base_optical, atol=1e-12)
        assert_allclose(a.boxes_xyxy, b.boxes_xyxy)


def test_sessions_compare_by_value(valid_session: dict[str, Any]) -> None:
    a, b = load_session(valid_session), load_session(copy.deepcopy(valid_session))
    assert a == b
    moved = load_session(with_edits(valid_session, ("views/0/pose/position", [0.0, 0.0, 0.1])))
    assert a != moved


def test_load_session_passes_a_session_through(valid_session: dict[str, Any]) -> None:
    s = load_session(valid_session)
    assert load_session(s) is s


# ---------------------------------------------------------------------- warnings
def test_partly_outside_box_is_clipped_with_warning(valid_session: dict[str, Any]) -> None:
    data = with_edits(valid_session, ("views/0/detections/0/bbox_xyxy", [-10.0, 400.0, 50.0, 500.0]))
    with pytest.warns(
        InputWarning,
        match=r"views\[0\]\.detections\[0\]\.bbox_xyxy: .* extends past the 640x480 image; clipped to \[0\.0, 400\.0, 50\.0, 480\.0\]",
    ):
        s = load_session(data)
    assert_allclose(s.views[0].boxes_xyxy, [[0.0, 400.0, 50.0, 480.0]])


def test_a_box_edge_near_the_float_range_end_is_clipped_with_a_plain_warning(valid_session: dict[str, Any]) -> None:
    # found by the detection-file property test: the message's rounding overflowed (a RuntimeWarning) at -1e308
    data = with_edits(valid_session, ("views/0/detections/0/bbox_xyxy", [-1e308, 400.0, 50.0, 470.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.warns(InputWarning, match=r"\[-1e\+308, 400\.0, 50\.0, 470\.0\] extends past .* clipped to \[0\.0, 400"):
            s = load_session(data)
    assert_allclose(s.views[0].boxes_xyxy, [[0.0, 400.0, 50.0, 470.0]])


def test_box_touching_the_image_edge_is_not_clipped(valid_session: dict[str, Any]) -> None:
    data = with_edits(valid_session, ("views/0/detections/0/bbox_xyxy", [0.0, 0.0, 640.0, 480.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = load_session(data)
    assert_allclose(s.views[0].boxes_xyxy, [[0.0, 0.0, 640.0, 480.0]])


def test_view_without_detections_warns_and_is_kept(valid_session: dict[str, Any]) -> None:
    data = with_edits(valid_session, ("views/0/detections", []))
    data["views"].append(copy.deepcopy(VALID_VIEW))
    with pytest.warns(InputWarning) as record:
        s = load_session(data)
    messages = [str(w.message) for w in record]
    assert any(re.search(r"views\[0\]: no detections; the view is kept", m) for m in messages)
    assert any("all 2 views have the same pose" in m for m in messages)  # the copied view: one viewpoint
    assert len(s.views) == 2
    assert s.views[0].detections == () and s.views[0].boxes_xyxy.shape == (0, 4)


@pytest.mark.parametrize("suffix", [".json", ".yaml"])
def test_warnings_name_the_file(valid_session: dict[str, Any], tmp_path: Path, suffix: str) -> None:
    path = write(tmp_path, with_edits(valid_session, ("views/0/detections/0/bbox_xyxy", [600.0, 220.0, 700.0, 260.0])), suffix)
    with pytest.warns(InputWarning, match="^" + re.escape(f"{path}: views[0].detections[0].bbox_xyxy")):
        load_session(path)


# ---------------------------------------------------------------------- errors
REFLECTION = [[-1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
SHEARED = [[1.0, 0.2, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
SCALED = [[2.0, 0.0, 0.0, 0.0], [0.0, 2.0, 0.0, 0.0], [0.0, 0.0, 2.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
BAD_LAST_ROW = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.5, 1.0]]
WITH_NAN = [[1.0, 0.0, 0.0, NAN], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
HFOV_CAMERA = {"width": 640, "height": 480, "hfov_deg": 69.0}
DIST = "camera/distortion"
POSE = "views/0/pose"
DET = "views/0/detections/0"
BOX = f"{DET}/bbox_xyxy"

#: (id, edits, regex the message must match from its start). Each row hits one branch of the loader.
BAD_INPUTS: list[tuple[str, list[tuple[str, Any]], str]] = [
    # top level
    (
        "unknown top-level field",
        [("cameras", {})],
        r"cameras: unknown field, expected one of \['camera', 'metadata', 'pose_frame', 'views', 'workspace'\]",
    ),
    ("missing camera", [("camera", DELETE)], r"camera: missing field, expected an object"),
    ("bad pose_frame", [("pose_frame", "link")], r"pose_frame: got 'link', expected one of \['optical', 'camera_link'\]"),
    ("missing views", [("views", DELETE)], r"views: missing field, expected a list of views"),
    ("views not a list", [("views", {"0": {}})], r"views: expected a list, got dict"),
    ("zero views", [("views", [])], r"views: empty, expected at least one view"),
    # camera
    ("camera not an object", [("camera", [640, 480])], r"camera: expected an object, got list"),
    ("unknown camera field", [("camera/focal", 3.0)], r"camera\.focal: unknown field"),
    ("missing width", [("camera/width", DELETE)], r"camera\.width: missing field, expected a positive integer"),
    ("missing height", [("camera/height", DELETE)], r"camera\.height: missing field"),
    ("negative height", [("camera/height", -480)], r"camera\.height: expected a positive integer \(pixels\), got -480"),
    ("float width", [("camera/width", 640.5)], r"camera\.width: expected a positive integer \(pixels\), got 640\.5"),
    ("bool width", [("camera/width", True)], r"camera\.width: expected a positive integer"),
    ("string width", [("camera/width", "640")], r"camera\.width: expected a positive integer \(pixels\), got '640'"),
    ("hfov and fx", [("camera/hfov_deg", 69.0)], r"camera: give either hfov_deg or fx/fy/cx/cy, not both"),
    (
        "hfov too wide",
        [("camera", {**HFOV_CAMERA, "hfov_deg": 180.0})],
        r"camera\.hfov_deg: got 180\.0, expected a value in \(0, 180\) degrees",
    ),
    ("hfov zero", [("camera", {**HFOV_CAMERA, "hfov_deg": 0})], r"camera\.hfov_deg: got 0\.0, expected a value in \(0, 180\)"),
    ("hfov not a number", [("camera", {**HFOV_CAMERA, "hfov_deg": "wide"})], r"camera\.hfov_deg: expected a number, got 'wide'"),
    ("hfov NaN", [("camera", {**HFOV_CAMERA, "hfov_deg": NAN})], r"camera\.hfov_deg: got nan, expected a finite number"),
    ("missing cy", [("camera/cy", DELETE)], r"camera\.cy: missing field, expected fx, fy, cx, cy \(pixels\) or hfov_deg"),
    ("no intrinsics", [("camera", {"width": 640, "height": 480})], r"camera\.fx: missing field"),
    ("zero fx", [("camera/fx", 0)], r"camera\.fx: got 0\.0, expected a positive focal length in pixels"),
    ("negative fy", [("camera/fy", -462.4)], r"camera\.fy: got -462\.4, expected a positive focal length"),
    ("NaN fx", [("camera/fx", NAN)], r"camera\.fx: got nan, expected a finite number"),
    ("inf cx", [("camera/cx", INF)], r"camera\.cx: got inf, expected a finite number"),
    ("string cy", [("camera/cy", "240")], r"camera\.cy: expected a number, got '240'"),
    ("distortion not an object", [(DIST, [0.1, 0, 0, 0])], r"camera\.distortion: expected an object, got list"),
    (
        "distortion unknown field",
        [(DIST, {"model": "plumb_bob", "coefficients": [0.1, 0, 0, 0], "k1": 0.1})],
        r"camera\.distortion\.k1: unknown field, expected one of \['coefficients', 'model'\]",
    ),
    (
        "distortion without coefficients",
        [(DIST, {"model": "plumb_bob"})],
        r"camera\.distortion\.coefficients: expected a list of numbers, got None",
    ),
    (
        "distortion coefficient not a number",
        [(DIST, {"model": "plumb_bob", "coefficients": [0.1, "x", 0, 0]})],
        r"camera\.distortion\.coefficients\[1\]: expected a number, got 'x'",
    ),
    (
        "distortion coefficient NaN",
        [(DIST, {"model": "plumb_bob", "coefficients": [0.1, 0, NAN, 0]})],
        r"camera\.distortion\.coefficients\[2\]: got nan, expected a finite number",
    ),
    (
        "unknown distortion model",
        [(DIST, {"model": "division", "coefficients": [0.1]})],
        r"camera\.distortion\.model: unknown model 'division'",
    ),
    (
        "wrong coefficient count",
        [(DIST, {"model": "plumb_bob", "coefficients": [0.1, 0, 0]})],
        r"camera\.distortion\.coefficients: model plumb_bob takes 4 or 5 coefficients, got 3",
    ),
    (
        "wrong fisheye count",
        [(DIST, {"model": "fisheye", "coefficients": [0.1, 0, 0, 0, 0]})],
        r"camera\.distortion\.coefficients: model equidistant takes 4 coefficients, got 5",
    ),
    # views and poses
    ("view not an object", [("views/0", "view")], r"views\[0\]: expected an object, got str"),
    ("unknown view field", [("views/0/camera", {})], r"views\[0\]\.camera: unknown field"),
    ("missing pose", [(POSE, DELETE)], r"views\[0\]\.pose: missing field, expected position \+ quaternion_xyzw or matrix"),
    (
        "pose not an object",
        [(POSE, [0, 0, 0, 0, 0, 0, 1])],
        r'views\[0\]\.pose: expected an object: \{"position": .* or \{"matrix": 4x4 rows\}, got list',
    ),
    ("unknown pose field", [(f"{POSE}/orientation", [0, 0, 0, 1])], r"views\[0\]\.pose\.orientation: unknown field"),
    (
        "missing position",
        [(f"{POSE}/position", DELETE)],
        r"views\[0\]\.pose\.position: missing field, expected \[x, y, z\] in metres",
    ),
    ("missing quaternion", [(f"{POSE}/quaternion_xyzw", DELETE)], r"views\[0\]\.pose\.quaternion_xyzw: missing field"),
    ("position too short", [(f"{POSE}/position", [0.0, 0.0])], r"views\[0\]\.pose\.position: expected 3 numbers, got 2"),
    (
        "position not a list",
        [(f"{POSE}/position", "0 0 0")],
        r"views\[0\]\.pose\.position: expected a list of 3 numbers, got '0 0 0'",
    ),
    (
        "position NaN",
        [(f"{POSE}/position", [0.0, NAN, 0.0])],
        r"views\[0\]\.pose\.position\[1\]: got nan, expected a finite number",
    ),
    (
        "position inf",
        [(f"{POSE}/position", [0.0, 0.0, -INF])],
        r"views\[0\]\.pose\.position\[2\]: got -inf, expected a finite number",
    ),
    ("position string entry", [(f"{POSE}/position", [0.0, "1", 0.0])], r"views\[0\]\.pose\.position\[1\]: expected a number"),
    (
        "non-unit quaternion",
        [(f"{POSE}/quaternion_xyzw", [0.0, 0.0, 0.0, 0.9])],
        r"views\[0\]\.pose\.quaternion_xyzw: norm 0\.9, expected 1 \(order is x, y, z, w\)",
    ),
    ("zero quaternion", [(f"{POSE}/quaternion_xyzw", [0, 0, 0, 0])], r"views\[0\]\.pose\.quaternion_xyzw: norm 0, expected 1"),
    (
        "quaternion too long",
        [(f"{POSE}/quaternion_xyzw", [0, 0, 0, 1, 0])],
        r"views\[0\]\.pose\.quaternion_xyzw: expected shape \[4\], got \[5\]",
    ),
    (
        "quaternion NaN",
        [(f"{POSE}/quaternion_xyzw", [0, 0, NAN, 1])],
        r"views\[0\]\.pose\.quaternion_xyzw: contains NaN or infinity",
    ),
    ("non-orthonormal matrix", [(POSE, {"matrix": SHEARED})], r"views\[0\]\.pose\.matrix: rotation block is not orthonormal"),
    ("scaled matrix", [(POSE, {"matrix": SCALED})], r"views\[0\]\.pose\.matrix: rotation block is not orthonormal"),
    (
        "reflection matrix",
        [(POSE, {"matrix": REFLECTION})],
        r"views\[0\]\.pose\.matrix: rotation block has determinant -1, expected \+1 \(a reflection",
    ),
    (
        "bad last row",
        [(POSE, {"matrix": BAD_LAST_ROW})],
        r"views\[0\]\.pose\.matrix: last row is \[0\.0, 0\.0, 0\.5, 1\.0\], expected \[0, 0, 0, 1\]",
    ),
    ("matrix 3x4", [(POSE, {"matrix": ROT_X_90[:3]})], r"views\[0\]\.pose\.matrix: expected shape \[4, 4\], got \[3, 4\]"),
    ("matrix NaN", [(POSE, {"matrix": WITH_NAN})], r"views\[0\]\.pose\.matrix: contains NaN or infinity"),
    (
        "matrix ragged",
        [(POSE, {"matrix": [[1, 0, 0], [0, 1]]})],
        r"views\[0\]\.pose\.matrix: expected numbers with shape \[4, 4\]",
    ),
    (
        "matrix and position",
        [(POSE, {"matrix": ROT_X_90, "position": [0, 0, 0]})],
        r"views\[0\]\.pose\.position: unknown field, expected one of \['matrix'\]",
    ),
    (
        "missing detections",
        [("views/0/detections", DELETE)],
        r"views\[0\]\.detections: missing field, expected a list \(may be empty\)",
    ),
    (
        "detections not a list",
        [("views/0/detections", {"bbox_xyxy": [1, 2, 3, 4]})],
        r"views\[0\]\.detections: expected a list, got dict",
    ),
    ("stamp not a number", [("views/0/stamp", "now")], r"views\[0\]\.stamp: expected a number, got 'now'"),
    ("image not a string", [("views/0/image", 7)], r"views\[0\]\.image: expected a file name \(string\), got 7"),
    # detections
    ("detection not an object", [(DET, [300, 220, 340, 260])], r"views\[0\]\.detections\[0\]: expected an object, got list"),
    ("unknown detection field", [(f"{DET}/confidence", 0.9)], r"views\[0\]\.detections\[0\]\.confidence: unknown field"),
    (
        "missing bbox",
        [(BOX, DELETE)],
        r"views\[0\]\.detections\[0\]\.bbox_xyxy: missing field, expected \[x1, y1, x2, y2\] in pixels",
    ),
    ("bbox too short", [(BOX, [300, 220, 340])], r"views\[0\]\.detections\[0\]\.bbox_xyxy: expected 4 numbers, got 3"),
    (
        "bbox NaN",
        [(BOX, [300, 220, NAN, 260])],
        r"views\[0\]\.detections\[0\]\.bbox_xyxy\[2\]: got nan, expected a finite number",
    ),
    ("bbox inf", [(BOX, [300, 220, 340, INF])], r"views\[0\]\.detections\[0\]\.bbox_xyxy\[3\]: got inf"),
    (
        "bbox x2 < x1",
        [(BOX, [340, 220, 300, 260])],
        r"views\[0\]\.detections\[0\]\.bbox_xyxy: \[340\.0, 220\.0, 300\.0, 260\.0\] has x2 <= x1 or y2 <= y1, expected x1 < x2 and y1 < y2",
    ),
    ("bbox x2 == x1", [(BOX, [300, 220, 300, 260])], r"views\[0\]\.detections\[0\]\.bbox_xyxy: .* has x2 <= x1"),
    ("bbox y2 < y1", [(BOX, [300, 260, 340, 220])], r"views\[0\]\.detections\[0\]\.bbox_xyxy: .* has x2 <= x1 or y2 <= y1"),
    (
        "bbox right of image",
        [(BOX, [640, 220, 700, 260])],
        r"views\[0\]\.detections\[0\]\.bbox_xyxy: \[640\.0, 220\.0, 700\.0, 260\.0\] lies entirely outside the 640x480 image",
    ),
    (
        "bbox left of image",
        [(BOX, [-60, 220, 0, 260])],
        r"views\[0\]\.detections\[0\]\.bbox_xyxy: .* lies entirely outside the 640x480 image",
    ),
    ("bbox above image", [(BOX, [300, -40, 340, -1])], r"views\[0\]\.detections\[0\]\.bbox_xyxy: .* lies entirely outside"),
    ("bbox below image", [(BOX, [300, 480, 340, 520])], r"views\[0\]\.detections\[0\]\.bbox_xyxy: .* lies entirely outside"),
    (
        "score above 1",
        [(f"{DET}/score", 1.5)],
        r"views\[0\]\.detections\[0\]\.score: got 1\.5, expected a confidence in \[0, 1\]",
    ),
    ("score not a number", [(f"{DET}/score", "high")], r"views\[0\]\.detections\[0\]\.score: expected a number, got 'high'"),
    (
        "mask not an object",
        [(f"{DET}/mask", [[0, 0], [1, 1]])],
        r"views\[0\]\.detections\[0\]\.mask: expected an object, got list",
    ),
    (
        "mask without polygon or RLE",
        [(f"{DET}/mask", {"points": []})],
        r"views\[0\]\.detections\[0\]\.mask: expected \{'polygon'",
    ),
    # later views and detections are named by their own index
    (
        "second view",
        [("views/1", {**VALID_VIEW, "pose": {"position": [0, 0, 0], "quaternion_xyzw": [1, 1, 0, 0]}})],
        r"views\[1\]\.pose\.quaternion_xyzw: norm 1\.414",
    ),
    (
        "second detection",
        [("views/0/detections/1", {"bbox_xyxy": [5, 5, 1, 9]})],
        r"views\[0\]\.detections\[1\]\.bbox_xyxy: .* has x2 <= x1",
    ),
    # workspace
    ("workspace not an object", [("workspace", [[0, 0, 0], [1, 1, 1]])], r"workspace: expected an object, got list"),
    (
        "unknown workspace field",
        [("workspace", {"min": [0, 0, 0], "max": [1, 1, 1], "frame": "base"})],
        r"workspace\.frame: unknown field",
    ),
    (
        "workspace missing max",
        [("workspace", {"min": [0, 0, 0]})],
        r"workspace\.max: missing field, expected \[x, y, z\] in metres, base frame",
    ),
    ("workspace short min", [("workspace", {"min": [0, 0], "max": [1, 1, 1]})], r"workspace\.min: expected 3 numbers, got 2"),
    (
        "workspace NaN",
        [("workspace", {"min": [0, 0, 0], "max": [1, NAN, 1]})],
        r"workspace\.max\[1\]: got nan, expected a finite number",
    ),
    (
        "workspace max <= min",
        [("workspace", {"min": [0, 0, 0], "max": [1, 0, 1]})],
        r"workspace: max \[1\.0, 0\.0, 1\.0\] must exceed min \[0\.0, 0\.0, 0\.0\] on every axis",
    ),
]


def _bad_input_params() -> list[Any]:
    return [pytest.param(edits, match, id=name) for name, edits, match in BAD_INPUTS]


def _prepare(valid: dict[str, Any], edits: list[tuple[str, Any]]) -> dict[str, Any]:
    data = copy.deepcopy(valid)
    if any(path.startswith("views/1") for path, _ in edits):
        data["views"].append(None)
    if any(path.startswith("views/0/detections/1") for path, _ in edits):
        data["views"][0]["detections"].append(None)
    for path, value in edits:
        edit(data, path, value)
    return data


@pytest.mark.parametrize(("edits", "match"), _bad_input_params())
def test_bad_input_is_rejected_naming_the_field(valid_session: dict[str, Any], edits: list[tuple[str, Any]], match: str) -> None:
    data = _prepare(valid_session, edits)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        with pytest.raises(InputError, match="^" + match) as info:
            load_session(data)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("suffix", [".json", ".yaml"])
@pytest.mark.parametrize(("edits", "match"), _bad_input_params())
def test_bad_file_is_rejected_naming_file_and_field(
    valid_session: dict[str, Any], tmp_path: Path, suffix: str, edits: list[tuple[str, Any]], match: str
) -> None:
    data = _prepare(valid_session, edits)
    path = write(tmp_path, data, suffix)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        with pytest.raises(InputError, match="^" + re.escape(f"{path}: ") + match):
            load_session(path)


def test_top_level_not_an_object(tmp_path: Path) -> None:
    path = write(tmp_path, [1, 2], ".json")
    with pytest.raises(InputError, match="^" + re.escape(f"{path}: (top level): expected an object, got list")):
        load_session(path)
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    with pytest.raises(InputError, match="^" + re.escape(f"{empty}: (top level): expected an object, got NoneType")):
        load_session(empty)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('{"camera": {"width": 640,}', r"not valid JSON at line 1, column 26: Expecting property name"),
        ('{"camera": 1}\n{"views": 2}', r"not valid JSON at line 2, column 1: Extra data"),
        ("", r"not valid JSON at line 1, column 1"),
    ],
)
def test_malformed_json(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "broken.json"
    path.write_text(text)
    with pytest.raises(InputError, match="^" + re.escape(f"{path}: ") + match):
        load_session(path)


@pytest.mark.parametrize("suffix", [".yaml", ".yml"])
def test_malformed_yaml(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"broken{suffix}"
    path.write_text("camera:\n  width: 640\n  height: [480\nviews: []\n")
    with pytest.raises(InputError, match="^" + re.escape(f"{path}: not valid YAML at line ") + r"\d+, column \d+: ") as info:
        load_session(path)
    assert "\n" not in str(info.value)


def test_missing_file_and_directory(tmp_path: Path) -> None:
    missing = tmp_path / "nope.json"
    with pytest.raises(InputError, match="^" + re.escape(f"{missing}: file not found")):
        load_session(missing)
    with pytest.raises(InputError, match="^" + re.escape(f"{tmp_path}: is a directory, expected a JSON or YAML file")):
        load_session(tmp_path)


def test_nan_from_json_text_is_rejected(tmp_path: Path, valid_session: dict[str, Any]) -> None:
    """JSON's non-standard NaN literal is parsed by Python and must still be refused."""
    path = tmp_path / "nan.json"
    path.write_text(json.dumps(valid_session).replace('462.4, "cx"', 'NaN, "cx"'))
    with pytest.raises(InputError, match="^" + re.escape(f"{path}: camera.fy: got nan, expected a finite number")):
        load_session(path)


# ---------------------------------------------------------------------- masks are validated at load
def _session_with_mask(mask):
    return {
        "camera": {"width": 640, "height": 480, "hfov_deg": 69.0},
        "views": [
            {
                "pose": {"position": [0, 0, 0], "quaternion_xyzw": [0, 0, 0, 1]},
                "detections": [{"bbox_xyxy": [300, 220, 340, 260], "mask": mask}],
            }
        ],
    }


@pytest.mark.parametrize(
    ("mask", "match"),
    [
        ({"polygon": [[1, 2], [3], [4, 5]]}, r"views\[0\]\.detections\[0\]\.mask\.polygon\[1\]: expected 2 numbers"),
        ({"polygon": "abc"}, r"mask\.polygon: expected a list of at least 3"),
        ({"polygon": [[1, 2], [3, 4]]}, r"mask\.polygon: expected a list of at least 3"),
        ({"size": [480, 640], "counts": "zzz!!"}, r"mask\.counts: not a valid COCO compressed RLE"),
        ({"size": [480, 640], "counts": [1, 2]}, r"mask\.counts: run lengths sum to 3"),
        (
            {"size": [100, 100], "counts": [10000]},
            r"mask\.size: got \[100, 100\], expected the image size \[height, width\] = \[480, 640\]",
        ),
        ({"size": [480, 640], "counts": [307200]}, r"mask\.counts: the mask is empty"),
    ],
)
def test_bad_masks_fail_at_load_with_the_file_name(tmp_path, mask, match):
    import json

    path = tmp_path / "s.json"
    path.write_text(json.dumps(_session_with_mask(mask)))
    with pytest.raises(InputError, match=match) as info:
        load_session(path)
    assert str(info.value).startswith(f"{path}: ")


def test_far_camera_position_warns_about_millimetres():
    data = _session_with_mask({"polygon": [[300, 220], [340, 220], [320, 260]]})
    data["views"][0]["pose"]["position"] = [100.0, 0.0, 450.0]
    with pytest.warns(InputWarning, match=r"views\[0\]\.pose\.position: camera 461 m from the base origin; positions are metres"):
        load_session(data)


@pytest.mark.parametrize(
    "box", [[300.0, float("nan"), 340.0, 260.0], [340.0, 220.0, 300.0, 260.0], [300.0, 220.0, 340.0], [0, 0, float("inf"), 5]]
)
def test_a_detection_built_in_code_refuses_a_box_no_detector_draws(box: list[float]) -> None:
    """A ``Detection`` made in code (not read from a file) is checked too: NaN, infinite, inverted or short boxes raise
    a one-line error naming the field; a box of zero width is kept (a detector may draw one at the image border)."""
    from monovisual3d.session import Detection

    with pytest.raises(InputError, match=r"^Detection\.bbox_xyxy: got .*expected 4 finite pixel coordinates"):
        Detection(np.array(box, dtype=float))
    assert Detection(np.array([5.0, 6.0, 5.0, 9.0])).bbox_xyxy.tolist() == [5.0, 6.0, 5.0, 9.0]
