"""The session loader: a JSON/YAML file or a parsed ``dict`` -> a validated :class:`~.model.Session`.

Every problem is one :class:`~monovisual3d.errors.InputError` line ``FILE: json.path: problem``; doubtful
but usable input (a box past the image, a camera kilometres away, views that cannot triangulate) is an
:class:`~monovisual3d.errors.InputWarning`. The numbers are checked by :mod:`monovisual3d.checks`.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import limits
from .._structured import read_structured_file
from ..camera import Camera, camera_from_dict
from ..checks import (
    check_position,
    check_quaternion_xyzw,
    expect_list,
    expect_object,
    finite_number,
    is_int,
    is_real,
    reject_unknown,
    vector,
)
from ..errors import InputError, InputWarning, excerpt, one_line
from ..file_kinds import wrong_kind
from ..frames import T_base_optical_from_T_base_cameralink, check_transform, transform_from_position_quaternion
from ..masks import rle_counts
from .baseline import geometry_warnings
from .diagnose import raw_box_causes, refusal_hint
from .model import Detection, Session, View, Workspace

POSE_FRAMES = ("optical", "camera_link")
#: A camera farther than this from the base origin (metres) is flagged: probably millimetres.
MAX_PLAUSIBLE_DISTANCE_M = 20.0
#: Largest ``track`` id of a detection (a bound that keeps ids plain JSON integers).
MAX_TRACK_ID = 2**31 - 1
#: Box coordinates beyond this (pixels) are left out of the session-level box tests (finite and far past any image).
MAX_BOX_COORDINATE = 1e9
#: Largest |class number| given as a detection's ``label`` (a bound that keeps the text of the number short).
MAX_CLASS_NUMBER = 10**18


def load_session(source: str | Path | dict[str, Any] | Session) -> Session:
    """Load and validate a session from a JSON/YAML file or an already-parsed dict.

    Parameters
    ----------
    source : path, dict or Session

    Returns
    -------
    Session

    Raises
    ------
    InputError
        With a one-line message ``FILE: json.path: problem``.

    Examples
    --------
    >>> s = load_session({"camera": {"width": 640, "height": 480, "hfov_deg": 69},
    ...                   "views": [{"pose": {"position": [0, 0, 0], "quaternion_xyzw": [0, 0, 0, 1]},
    ...                              "detections": [{"bbox_xyxy": [300, 220, 340, 260]}]}]})
    >>> len(s.views)
    1
    """
    if isinstance(source, Session):
        return source
    if isinstance(source, dict):
        return session_from_dict(source, None)
    if not isinstance(source, (str, Path)):
        raise InputError(f"load_session: expected a file path, a dict or a Session, got {type(source).__name__}")
    data = read_structured_file(source)
    return session_from_dict(data, one_line(str(source)))


def session_from_dict(data: Any, source: str | None = None) -> Session:
    """Validate a parsed session object; errors are prefixed with ``source``."""
    try:
        return _session_from_dict(data, source)
    except InputError as exc:
        hint = wrong_kind(data, "session")  # a truth or result file given in place of a session: say so
        if hint is not None:
            raise InputError(f"{source}: {hint}" if source else hint) from None
        if source and not str(exc).startswith(f"{source}:"):
            raise InputError(f"{source}: {exc}") from None
        raise


def _session_from_dict(data: Any, source: str | None) -> Session:
    expect_object(data, "(top level)")
    reject_unknown(data, {"camera", "pose_frame", "views", "workspace", "metadata"}, "")
    if "camera" not in data:
        raise InputError("camera: missing field, expected an object with width, height and fx/fy/cx/cy or hfov_deg")
    camera = camera_from_dict(data["camera"])
    pose_frame = data.get("pose_frame", "optical")
    if pose_frame not in POSE_FRAMES:
        raise InputError(f"pose_frame: got {excerpt(pose_frame)}, expected one of {list(POSE_FRAMES)}")
    if "views" not in data:
        raise InputError("views: missing field, expected a list of views")
    views_data = expect_list(data["views"], "views")
    if not views_data:
        raise InputError("views: empty, expected at least one view")
    if len(views_data) > limits.MAX_VIEWS:
        raise InputError(f"views: {len(views_data)} views, more than the {limits.MAX_VIEWS:,} accepted (limits.MAX_VIEWS)")
    try:
        views = tuple(_view_from_dict(v, f"views[{i}]", camera, pose_frame, source) for i, v in enumerate(views_data))
    except InputError as exc:  # a refused box: say which convention the boxes as written are probably in
        hint = refusal_hint(camera, _boxes_as_written(views_data)) if "bbox_xyxy" in str(exc) else None
        if hint is None:
            raise
        raise InputError(f"{exc}; {hint}") from None
    workspace = None
    if data.get("workspace") is not None:
        workspace = workspace_from_dict(data["workspace"], "workspace")
    poses = np.stack([v.T_base_optical for v in views])
    causes = raw_box_causes(camera, poses, _boxes_as_written(views_data))
    session = Session(camera=camera, views=views, workspace=workspace, source=source, causes=tuple(causes))
    prefix = f"{source}: " if source else ""
    for message in geometry_warnings(session):
        warnings.warn(InputWarning(prefix + message), stacklevel=4)
    return session


def _boxes_as_written(views_data: list[Any]) -> list[NDArray[np.float64]]:
    """Per view, its boxes as written (before clipping), shape (M_i, 4): those that are four finite numbers."""
    out = []
    for view in views_data:
        dets = view.get("detections") if isinstance(view, dict) else None
        rows = []
        for det in dets if isinstance(dets, list) else []:
            box = det.get("bbox_xyxy") if isinstance(det, dict) else None
            if isinstance(box, list) and len(box) == 4 and all(is_real(x) and abs(x) < MAX_BOX_COORDINATE for x in box):
                rows.append([float(x) for x in box])
        out.append(np.array(rows, dtype=float).reshape(-1, 4))
    return out


def pose_from_dict(data: Any, where: str) -> NDArray[np.float64]:
    """4x4 transform from ``{"position", "quaternion_xyzw"}`` or ``{"matrix"}``."""
    expect_object(data, where, 'an object: {"position": [x, y, z], "quaternion_xyzw": [qx, qy, qz, qw]} or {"matrix": 4x4 rows}')
    if "matrix" in data:
        reject_unknown(data, {"matrix"}, where)
        T = check_transform(data["matrix"], where=f"{where}.matrix")
        check_position(T[:3, 3], f"{where}.matrix")
        return T
    reject_unknown(data, {"position", "quaternion_xyzw"}, where)
    if "position" not in data:
        raise InputError(f"{where}.position: missing field, expected [x, y, z] in metres (or give 'matrix')")
    if "quaternion_xyzw" not in data:
        raise InputError(f"{where}.quaternion_xyzw: missing field, expected [qx, qy, qz, qw] (or give 'matrix')")
    position = vector(data["position"], 3, f"{where}.position")
    check_position(position, f"{where}.position")
    q = check_quaternion_xyzw(data["quaternion_xyzw"], where=f"{where}.quaternion_xyzw")
    return transform_from_position_quaternion(position, q)


def workspace_from_dict(data: Any, where: str) -> Workspace:
    expect_object(data, where)
    reject_unknown(data, {"min", "max"}, where)
    for k in ("min", "max"):
        if k not in data:
            raise InputError(f"{where}.{k}: missing field, expected [x, y, z] in metres, base frame")
    lo = vector(data["min"], 3, f"{where}.min")
    hi = vector(data["max"], 3, f"{where}.max")
    check_position(lo, f"{where}.min")
    check_position(hi, f"{where}.max")
    if np.any(hi <= lo):
        raise InputError(f"{where}: max {hi.tolist()} must exceed min {lo.tolist()} on every axis")
    return Workspace(lo, hi)


def _view_from_dict(data: Any, where: str, camera: Camera, pose_frame: str, source: str | None) -> View:
    expect_object(data, where)
    reject_unknown(data, {"pose", "detections", "image", "stamp", "name"}, where)
    if "pose" not in data:
        raise InputError(f"{where}.pose: missing field, expected position + quaternion_xyzw or matrix")
    T = pose_from_dict(data["pose"], f"{where}.pose")
    distance = float(np.linalg.norm(T[:3, 3]))
    if distance > MAX_PLAUSIBLE_DISTANCE_M:
        key = "matrix" if "matrix" in data["pose"] else "position"
        where_src = f"{source}: " if source else ""
        warnings.warn(
            InputWarning(
                f"{where_src}{where}.pose.{key}: camera {distance:.0f} m from the base origin; positions are metres (millimetres by mistake?)"
            ),
            stacklevel=3,
        )
    if pose_frame == "camera_link":
        T = T_base_optical_from_T_base_cameralink(T)
    dets_data = data.get("detections")
    if dets_data is None:
        raise InputError(f"{where}.detections: missing field, expected a list (may be empty)")
    expect_list(dets_data, f"{where}.detections")
    if len(dets_data) > limits.MAX_DETECTIONS_PER_VIEW:
        raise InputError(
            f"{where}.detections: {len(dets_data)} detections, more than the {limits.MAX_DETECTIONS_PER_VIEW:,} accepted per view "
            "(limits.MAX_DETECTIONS_PER_VIEW)"
        )
    prefix = f"{source}: " if source else ""
    if not dets_data:
        warnings.warn(
            InputWarning(f"{prefix}{where}: no detections; the view is kept, but it has no box to localise with"),
            stacklevel=3,
        )
    dets = tuple(_detection_from_dict(d, f"{where}.detections[{j}]", camera, prefix) for j, d in enumerate(dets_data))
    _check_tracks(dets, f"{where}.detections")
    stamp = data.get("stamp")
    if stamp is not None:
        stamp = finite_number(stamp, f"{where}.stamp", limits.MAX_ABS_STAMP_S, "seconds")
    image = data.get("image")
    if image is not None and not isinstance(image, str):
        raise InputError(f"{where}.image: expected a file name (string), got {excerpt(image)}")
    return View(T_base_optical=T, detections=dets, image=image, stamp=stamp)


def _rounded(values: NDArray[np.float64]) -> list[float]:
    """Pixel values to two decimals for a message (Python's round: no overflow near the float range's ends)."""
    return [round(float(x), 2) for x in values]


def _detection_from_dict(data: Any, where: str, camera: Camera, prefix: str) -> Detection:
    expect_object(data, where)
    reject_unknown(data, {"bbox_xyxy", "score", "label", "mask", "class_id", "track"}, where)
    if "bbox_xyxy" not in data:
        raise InputError(f"{where}.bbox_xyxy: missing field, expected [x1, y1, x2, y2] in pixels")
    box = vector(data["bbox_xyxy"], 4, f"{where}.bbox_xyxy")
    x1, y1, x2, y2 = box
    if x2 <= x1 or y2 <= y1:
        raise InputError(f"{where}.bbox_xyxy: {box.tolist()} has x2 <= x1 or y2 <= y1, expected x1 < x2 and y1 < y2")
    W, H = camera.width, camera.height
    if x2 <= 0 or y2 <= 0 or x1 >= W or y1 >= H:
        raise InputError(f"{where}.bbox_xyxy: {_rounded(box)} lies entirely outside the {W}x{H} image")
    clipped = np.array([max(x1, 0.0), max(y1, 0.0), min(x2, float(W)), min(y2, float(H))])
    if not np.array_equal(clipped, box):
        warnings.warn(
            InputWarning(
                f"{prefix}{where}.bbox_xyxy: {_rounded(box)} extends past the {W}x{H} image; clipped to {_rounded(clipped)}"
            ),
            stacklevel=4,
        )
    score = data.get("score")
    if score is not None:
        score = finite_number(score, f"{where}.score")
        if not 0.0 <= score <= 1.0:
            raise InputError(f"{where}.score: got {score}, expected a confidence in [0, 1]")
    label = data.get("label")
    if label is not None and not isinstance(label, str):
        if not is_real(label):
            raise InputError(f"{where}.label: expected a class name (text), got {excerpt(label)}")
        if is_int(label) and abs(int(label)) > MAX_CLASS_NUMBER:
            raise InputError(f"{where}.label: got {excerpt(label)}, expected a class name (text) or a class number")
        label = str(label)
    mask = data.get("mask")
    if mask is not None:
        _check_mask(mask, f"{where}.mask", camera)
    track = data.get("track")
    if track is not None:
        if not is_int(track) or not 0 <= track <= MAX_TRACK_ID:
            raise InputError(f"{where}.track: expected an object number (integer 0 to {MAX_TRACK_ID:,}), got {excerpt(track)}")
        track = int(track)
    return Detection(bbox_xyxy=clipped, score=score, label=label, mask=mask, track=track)


def _check_tracks(dets: tuple[Detection, ...], where: str) -> None:
    """One box per track and view: a repeated track id in a view is an error naming both detections."""
    first: dict[int, int] = {}
    for j, d in enumerate(dets):
        if d.track is not None and first.setdefault(d.track, j) != j:
            msg = f"{d.track} repeats the track of detections[{first[d.track]}], expected one box per object and view"
            raise InputError(f"{where}[{j}].track: {msg}")


def _check_mask(mask: Any, where: str, camera: Camera) -> None:
    """Validate an instance mask now, so that a bad mask fails at load with the session's file name."""
    expect_object(mask, where)
    if "polygon" in mask:
        reject_unknown(mask, {"polygon"}, where)
        poly = mask["polygon"]
        if not isinstance(poly, list) or len(poly) < 3:
            raise InputError(f"{where}.polygon: expected a list of at least 3 [u, v] points (pixels)")
        if len(poly) > limits.MAX_POLYGON_POINTS:
            raise InputError(f"{where}.polygon: {len(poly)} points, more than the {limits.MAX_POLYGON_POINTS} accepted")
        W, H = camera.width, camera.height
        m = limits.POLYGON_MARGIN_IMAGES
        for i, pt in enumerate(poly):
            u, v = vector(pt, 2, f"{where}.polygon[{i}]")
            if not (-m * W <= u <= (1 + m) * W and -m * H <= v <= (1 + m) * H):
                raise InputError(
                    f"{where}.polygon[{i}]: [{u:.6g}, {v:.6g}] lies more than one image size outside the {W}x{H} image"
                )
        return
    if not {"counts", "size"} <= set(mask):
        raise InputError(f"{where}: expected {{'polygon': [[u, v], ...]}} or COCO RLE {{'size': [h, w], 'counts': ...}}")
    reject_unknown(mask, {"counts", "size"}, where)
    size = mask["size"]
    expected = [camera.height, camera.width]
    if not isinstance(size, list) or len(size) != 2 or [v for v in size if not is_int(v)]:
        raise InputError(f"{where}.size: expected [height, width] = {expected}, got {excerpt(size)}")
    if size != expected:
        raise InputError(f"{where}.size: got {excerpt(size)}, expected the image size [height, width] = {expected}")
    try:
        counts = rle_counts(mask)  # checked run by run: the mask is not decoded here
    except InputError as exc:
        raise InputError(f"{where}.{str(exc).removeprefix('mask.')}") from None
    if not any(counts[1::2]):
        raise InputError(f"{where}.counts: the mask is empty, expected the detection's pixels")
