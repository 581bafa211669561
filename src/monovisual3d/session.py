"""The session file: camera, views (pose + detections) and optional workspace.

A session is the input contract of :func:`monovisual3d.localize`. It is read
from JSON or YAML (same structure), validated on load, and every problem is
reported as one line that names the file, the JSON path and what was expected,
for example ``session.json: views[3].pose.quaternion_xyzw: norm 0.71, expected 1``.

See the README ("Session format") for the full description.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import limits
from ._structured import load_structured
from .camera import Camera, camera_from_dict
from .checks import expect_object as _expect_object
from .checks import finite_number as _number
from .checks import reject_unknown as _reject_unknown
from .errors import InputError, InputWarning, excerpt, one_line
from .file_kinds import wrong_kind
from .frames import (
    T_base_optical_from_T_base_cameralink,
    check_quaternion_xyzw,
    check_transform,
    position_quaternion_from_transform,
    transform_from_position_quaternion,
)
from .masks import rle_counts

POSE_FRAMES = ("optical", "camera_link")
#: A camera farther than this from the base origin (metres) is flagged: probably millimetres.
MAX_PLAUSIBLE_DISTANCE_M = 20.0
#: Largest ``track`` id of a detection (a bound that keeps ids plain JSON integers).
MAX_TRACK_ID = 2**31 - 1


def _fields_equal(self: Any, other: object) -> bool:
    """Dataclass equality that compares ndarray fields by value (the generated ``__eq__`` raises on arrays)."""
    if other.__class__ is not self.__class__:
        return NotImplemented
    for f in fields(self):
        a, b = getattr(self, f.name), getattr(other, f.name)
        if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
            if not np.array_equal(a, b):
                return False
        elif a != b:
            return False
    return True


@dataclass(frozen=True, eq=False)
class Detection:
    """One detected object in one image.

    Attributes
    ----------
    bbox_xyxy : ndarray, shape (4,), float64, pixels ``(x1, y1, x2, y2)``, x1 < x2, y1 < y2
    score : float or None, detector confidence in [0, 1]
    label : str or None
    mask : dict or None
        Optional instance mask: ``{"polygon": [[u, v], ...]}`` or COCO RLE
        ``{"size": [height, width], "counts": ...}``.
    track : int or None, >= 0: the object this box belongs to, when the association across
        views is known (a tracker, an annotated data set); methods that associate may use it
    """

    bbox_xyxy: NDArray[np.float64]
    score: float | None = None
    label: str | None = None
    mask: dict[str, Any] | None = None
    track: int | None = None

    __eq__ = _fields_equal  # ndarray fields: compare by value, not elementwise

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"bbox_xyxy": [float(v) for v in self.bbox_xyxy]}
        if self.score is not None:
            out["score"] = float(self.score)
        if self.label is not None:
            out["label"] = self.label
        if self.mask is not None:
            out["mask"] = self.mask
        if self.track is not None:
            out["track"] = int(self.track)
        return out


@dataclass(frozen=True, eq=False)
class View:
    """One camera pose with the detections made there.

    Attributes
    ----------
    T_base_optical : ndarray, shape (4, 4), the optical frame expressed in the base frame
    detections : tuple of Detection
    image : str or None, the image file the detections came from
    stamp : float or None, seconds
    """

    T_base_optical: NDArray[np.float64]
    detections: tuple[Detection, ...] = ()
    image: str | None = None
    stamp: float | None = None

    __eq__ = _fields_equal

    @property
    def boxes_xyxy(self) -> NDArray[np.float64]:
        """All boxes, shape (N, 4), pixels."""
        if not self.detections:
            return np.zeros((0, 4))
        return np.stack([d.bbox_xyxy for d in self.detections])

    def to_dict(self) -> dict[str, Any]:
        position, q = position_quaternion_from_transform(self.T_base_optical)
        out: dict[str, Any] = {
            "pose": {"position": position.tolist(), "quaternion_xyzw": q.tolist()},
            "detections": [d.to_dict() for d in self.detections],
        }
        if self.image is not None:
            out["image"] = self.image
        if self.stamp is not None:
            out["stamp"] = self.stamp
        return out


@dataclass(frozen=True, eq=False)
class Workspace:
    """Axis-aligned box in the base frame, metres: ``min`` (3,), ``max`` (3,)."""

    min: NDArray[np.float64]
    max: NDArray[np.float64]

    __eq__ = _fields_equal

    def to_dict(self) -> dict[str, Any]:
        return {"min": self.min.tolist(), "max": self.max.tolist()}


@dataclass(frozen=True)
class Session:
    """A validated session: camera, views and optional workspace."""

    camera: Camera
    views: tuple[View, ...]
    workspace: Workspace | None = None
    source: str | None = field(default=None, compare=False)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "camera": self.camera.to_dict(),
            "pose_frame": "optical",
            "views": [v.to_dict() for v in self.views],
        }
        if self.workspace is not None:
            out["workspace"] = self.workspace.to_dict()
        return out

    def to_json(self, path: str | Path | None = None, indent: int = 2) -> str:
        """The session as JSON text; also written to ``path`` when given."""
        text = json.dumps(self.to_dict(), indent=indent)
        if path is not None:
            Path(path).write_text(text + "\n")
        return text


# ---------------------------------------------------------------------- loading
def read_structured_file(path: str | Path) -> Any:
    """Read JSON or YAML (by suffix) with a one-line error for malformed or hostile content.

    Strict UTF-8, no duplicate keys, bounded size, nesting and YAML aliases, no YAML
    tags (see :mod:`monovisual3d.limits`).
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{one_line(str(path))}: is a directory, expected a JSON or YAML file")
    return load_structured(path)


def parse_structured_text(text: str, path: str | Path) -> Any:
    """Parse JSON or YAML text read from ``path`` (YAML by suffix), with the checks and errors of :func:`read_structured_file`."""
    from ._structured import load_json, load_yaml

    if Path(path).suffix.lower() in (".yaml", ".yml"):
        return load_yaml(text, str(path))
    return load_json(text, str(path))


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
    _expect_object(data, "(top level)")
    _reject_unknown(data, {"camera", "pose_frame", "views", "workspace", "metadata"}, "")
    if "camera" not in data:
        raise InputError("camera: missing field, expected an object with width, height and fx/fy/cx/cy or hfov_deg")
    camera = camera_from_dict(data["camera"])
    pose_frame = data.get("pose_frame", "optical")
    if pose_frame not in POSE_FRAMES:
        raise InputError(f"pose_frame: got {excerpt(pose_frame)}, expected one of {list(POSE_FRAMES)}")
    if "views" not in data:
        raise InputError("views: missing field, expected a list of views")
    views_data = data["views"]
    if not isinstance(views_data, list):
        raise InputError(f"views: expected a list, got {type(views_data).__name__}")
    if not views_data:
        raise InputError("views: empty, expected at least one view")
    if len(views_data) > limits.MAX_VIEWS:
        raise InputError(f"views: {len(views_data)} views, more than the {limits.MAX_VIEWS:,} accepted (limits.MAX_VIEWS)")
    views = tuple(_view_from_dict(v, f"views[{i}]", camera, pose_frame, source) for i, v in enumerate(views_data))
    workspace = None
    if data.get("workspace") is not None:
        workspace = workspace_from_dict(data["workspace"], "workspace")
    session = Session(camera=camera, views=views, workspace=workspace, source=source)
    prefix = f"{source}: " if source else ""
    for message in geometry_warnings(session):
        warnings.warn(InputWarning(prefix + message), stacklevel=4)
    return session


def pose_from_dict(data: Any, where: str) -> NDArray[np.float64]:
    """4x4 transform from ``{"position", "quaternion_xyzw"}`` or ``{"matrix"}``."""
    _expect_object(data, where)
    if "matrix" in data:
        _reject_unknown(data, {"matrix"}, where)
        T = check_transform(data["matrix"], where=f"{where}.matrix")
        _check_position(T[:3, 3], f"{where}.matrix")
        return T
    _reject_unknown(data, {"position", "quaternion_xyzw"}, where)
    if "position" not in data:
        raise InputError(f"{where}.position: missing field, expected [x, y, z] in metres (or give 'matrix')")
    if "quaternion_xyzw" not in data:
        raise InputError(f"{where}.quaternion_xyzw: missing field, expected [qx, qy, qz, qw] (or give 'matrix')")
    position = _vector(data["position"], 3, f"{where}.position")
    _check_position(position, f"{where}.position")
    q = check_quaternion_xyzw(data["quaternion_xyzw"], where=f"{where}.quaternion_xyzw")
    return transform_from_position_quaternion(position, q)


def workspace_from_dict(data: Any, where: str) -> Workspace:
    _expect_object(data, where)
    _reject_unknown(data, {"min", "max"}, where)
    for k in ("min", "max"):
        if k not in data:
            raise InputError(f"{where}.{k}: missing field, expected [x, y, z] in metres, base frame")
    lo = _vector(data["min"], 3, f"{where}.min")
    hi = _vector(data["max"], 3, f"{where}.max")
    _check_position(lo, f"{where}.min")
    _check_position(hi, f"{where}.max")
    if np.any(hi <= lo):
        raise InputError(f"{where}: max {hi.tolist()} must exceed min {lo.tolist()} on every axis")
    return Workspace(lo, hi)


def _view_from_dict(data: Any, where: str, camera: Camera, pose_frame: str, source: str | None) -> View:
    _expect_object(data, where)
    _reject_unknown(data, {"pose", "detections", "image", "stamp", "name"}, where)
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
    if not isinstance(dets_data, list):
        raise InputError(f"{where}.detections: expected a list, got {type(dets_data).__name__}")
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
        stamp = _number(stamp, f"{where}.stamp", limits.MAX_ABS_STAMP_S, "seconds")
    image = data.get("image")
    if image is not None and not isinstance(image, str):
        raise InputError(f"{where}.image: expected a file name (string), got {excerpt(image)}")
    return View(T_base_optical=T, detections=dets, image=image, stamp=stamp)


def _detection_from_dict(data: Any, where: str, camera: Camera, prefix: str) -> Detection:
    _expect_object(data, where)
    _reject_unknown(data, {"bbox_xyxy", "score", "label", "mask", "class_id", "track"}, where)
    if "bbox_xyxy" not in data:
        raise InputError(f"{where}.bbox_xyxy: missing field, expected [x1, y1, x2, y2] in pixels")
    box = _vector(data["bbox_xyxy"], 4, f"{where}.bbox_xyxy")
    x1, y1, x2, y2 = box
    if x2 <= x1 or y2 <= y1:
        raise InputError(f"{where}.bbox_xyxy: {box.tolist()} has x2 <= x1 or y2 <= y1, expected x1 < x2 and y1 < y2")
    W, H = camera.width, camera.height
    if x2 <= 0 or y2 <= 0 or x1 >= W or y1 >= H:
        raise InputError(f"{where}.bbox_xyxy: {box.tolist()} lies entirely outside the {W}x{H} image")
    clipped = np.array([max(x1, 0.0), max(y1, 0.0), min(x2, float(W)), min(y2, float(H))])
    if not np.array_equal(clipped, box):
        warnings.warn(
            InputWarning(
                f"{prefix}{where}.bbox_xyxy: {box.tolist()} extends past the {W}x{H} image; clipped to {clipped.tolist()}"
            ),
            stacklevel=4,
        )
    score = data.get("score")
    if score is not None:
        score = _number(score, f"{where}.score")
        if not 0.0 <= score <= 1.0:
            raise InputError(f"{where}.score: got {score}, expected a confidence in [0, 1]")
    label = data.get("label")
    if label is not None and not isinstance(label, str):
        if isinstance(label, (bool, np.bool_)) or not isinstance(label, (int, float, np.integer, np.floating)):
            raise InputError(f"{where}.label: expected a class name (text), got {excerpt(label)}")
        if isinstance(label, (int, np.integer)) and abs(int(label)) > 10**18:
            raise InputError(f"{where}.label: got {excerpt(label)}, expected a class name (text) or a class number")
        label = str(label)
    mask = data.get("mask")
    if mask is not None:
        _check_mask(mask, f"{where}.mask", camera)
    track = data.get("track")
    if track is not None:
        if isinstance(track, (bool, np.bool_)) or not isinstance(track, (int, np.integer)) or not 0 <= track <= MAX_TRACK_ID:
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
    _expect_object(mask, where)
    if "polygon" in mask:
        _reject_unknown(mask, {"polygon"}, where)
        poly = mask["polygon"]
        if not isinstance(poly, list) or len(poly) < 3:
            raise InputError(f"{where}.polygon: expected a list of at least 3 [u, v] points (pixels)")
        if len(poly) > limits.MAX_POLYGON_POINTS:
            raise InputError(f"{where}.polygon: {len(poly)} points, more than the {limits.MAX_POLYGON_POINTS} accepted")
        W, H = camera.width, camera.height
        m = limits.POLYGON_MARGIN_IMAGES
        for i, pt in enumerate(poly):
            u, v = _vector(pt, 2, f"{where}.polygon[{i}]")
            if not (-m * W <= u <= (1 + m) * W and -m * H <= v <= (1 + m) * H):
                raise InputError(
                    f"{where}.polygon[{i}]: [{u:.6g}, {v:.6g}] lies more than one image size outside the {W}x{H} image"
                )
        return
    if not {"counts", "size"} <= set(mask):
        raise InputError(f"{where}: expected {{'polygon': [[u, v], ...]}} or COCO RLE {{'size': [h, w], 'counts': ...}}")
    _reject_unknown(mask, {"counts", "size"}, where)
    size = mask["size"]
    expected = [camera.height, camera.width]
    if not isinstance(size, list) or len(size) != 2 or [v for v in size if isinstance(v, bool) or not isinstance(v, int)]:
        raise InputError(f"{where}.size: expected [height, width] = {expected}, got {excerpt(size)}")
    if size != expected:
        raise InputError(f"{where}.size: got {excerpt(size)}, expected the image size [height, width] = {expected}")
    try:
        counts = rle_counts(mask)  # checked run by run: the mask is not decoded here
    except InputError as exc:
        raise InputError(f"{where}.{str(exc).removeprefix('mask.')}") from None
    if not any(counts[1::2]):
        raise InputError(f"{where}.counts: the mask is empty, expected the detection's pixels")


# ---------------------------------------------------------------------- geometry
#: Views whose camera positions span less than this angle, seen from the scene, cannot triangulate depth well.
MIN_BASELINE_DEG = 3.0
#: Views closer than this (metres) and turned less than :data:`SAME_POSE_DEG` count as the same pose: a
#: millimetre and a tenth of a degree are below what arm kinematics repeat.
SAME_POSE_M = 1e-3
SAME_POSE_DEG = 0.1
#: Above this condition number the optical axes are taken as parallel (no point closest to all of them).
PARALLEL_AXES_CONDITION = 1e6
#: With parallel optical axes the scene point is taken this far in front of the cameras, metres.
PARALLEL_AXES_DEPTH_M = 1.0
#: A camera closer than this to the scene point (metres, rounding level) gives no direction to measure angles from.
AT_SCENE_POINT_M = 1e-9


def geometry_warnings(session: Session, *, single_view: bool = False) -> list[str]:
    """Warnings about view geometry that cannot triangulate depth (empty when the views are well spread).

    Parameters
    ----------
    session : Session
    single_view : bool
        Also warn when the session has a single view (a method asked to localise from one view).

    Returns
    -------
    list of str, one-line messages naming the field (``views``)

    Notes
    -----
    The scene point is the workspace centre when there is a workspace, else the
    point closest to all optical axes (1 m in front of the cameras when the axes
    are parallel). The baseline is the largest angle between two camera
    positions seen from that point.
    """
    views = session.views
    n = len(views)
    if n == 1:
        return ["views: a single view; depth comes from the box size alone, give views from several poses"] if single_view else []
    T = np.stack([v.T_base_optical for v in views])
    P, Z = T[:, :3, 3], T[:, :3, 2]
    R0 = T[0, :3, :3]
    cos_rot = np.clip((np.einsum("nij,ij->n", T[:, :3, :3], R0) - 1) / 2, -1.0, 1.0)
    if np.all(np.linalg.norm(P - P[0], axis=1) < SAME_POSE_M) and np.all(np.degrees(np.arccos(cos_rot)) < SAME_POSE_DEG):
        return [f"views: all {n} views have the same pose; depth cannot be triangulated from one viewpoint"]
    if session.workspace is not None:
        target = 0.5 * (session.workspace.min + session.workspace.max)
    else:
        A = n * np.eye(3) - Z.T @ Z
        b = (P - Z * np.sum(Z * P, axis=1, keepdims=True)).sum(0)
        target = P.mean(0) + PARALLEL_AXES_DEPTH_M * Z.mean(0)
        if np.linalg.cond(A) < PARALLEL_AXES_CONDITION:
            candidate = np.linalg.solve(A, b)
            if np.all(np.sum((candidate - P) * Z, axis=1) > 0):
                target = candidate
    d = P - target
    norm = np.linalg.norm(d, axis=1)
    if np.any(norm < AT_SCENE_POINT_M):  # a camera at the scene point: no angle to measure
        return []
    u = d / norm[:, None]
    far = int(np.argmin(u @ u[0]))  # two passes of farthest direction: the largest pairwise angle, to a factor < 2
    span = float(np.degrees(np.arccos(np.clip(np.min(u @ u[far]), -1.0, 1.0))))
    if span < MIN_BASELINE_DEG:
        where = ", ".join(f"{x:.3g}" for x in target)
        return [
            f"views: the camera positions span {span:.2g} degrees seen from the scene (near [{where}] m), under "
            f"{MIN_BASELINE_DEG:g}; depth is poorly determined, move the camera farther between views"
        ]
    return []


# ---------------------------------------------------------------------- helpers
def _check_position(p: NDArray[np.float64], where: str) -> None:
    """Refuse a position with a coordinate beyond :data:`~monovisual3d.limits.MAX_ABS_POSITION_M` metres."""
    big = float(np.max(np.abs(p)))
    if not big <= limits.MAX_ABS_POSITION_M:
        raise InputError(f"{where}: coordinate {big:.3g} m, beyond the {limits.MAX_ABS_POSITION_M:g} m accepted (wrong units?)")


def _vector(value: Any, n: int, where: str) -> NDArray[np.float64]:
    if isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise InputError(f"{where}: expected a list of {n} numbers, got {excerpt(value)}")
    if len(value) != n:
        raise InputError(f"{where}: expected {n} numbers, got {len(value)}")
    return np.array([_number(v, f"{where}[{i}]") for i, v in enumerate(value)])
