"""Pose sources: TUM and CSV trajectories, JSON lists of 4x4 matrices, hand-eye calibrations.

A :class:`PoseTrajectory` holds the poses of one moving frame in the robot's
base frame, ``T_base_frame``: the camera itself, or the end effector when a
hand-eye calibration ``T_ee_camera`` is given (eye-in-hand:
``T_base_camera = T_base_ee @ T_ee_camera``, :func:`T_base_camera_from_T_base_ee`).
Poses are matched to images by file name or interpolated to detection stamps
(:func:`interpolate_poses`: linear in position, slerp in rotation).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation, Slerp

from ..checks import as_array, as_float, check_quaternion_xyzw, expect_object
from ..errors import InputError, excerpt
from ..frames import check_transform, invert_transform, transform_from_position_quaternion
from ._parse import check_angles, check_rows, check_stamp, check_translations, load_structured, read_table_text
from .detections import read_csv_table

POSE_FORMATS = ("tum", "csv", "json")
#: Units of positions in pose files, as metres per unit.
POSITION_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}


@dataclass(frozen=True)
class PoseTrajectory:
    """Poses of one frame (camera or end effector) in the base frame.

    Attributes
    ----------
    T_base_frame : ndarray, shape (N, 4, 4), float64, metres
    stamps : ndarray, shape (N,), seconds, strictly increasing; or None
    images : tuple of str (N,) or None, the image taken at each pose
    source : str or None
    """

    T_base_frame: NDArray[np.float64]
    stamps: NDArray[np.float64] | None = None
    images: tuple[str, ...] | None = None
    source: str | None = None

    def __len__(self) -> int:
        return len(self.T_base_frame)


def make_trajectory(
    T: list[NDArray[np.float64]], stamps: list[float | None], images: list[str | None], source: str
) -> PoseTrajectory:
    """Assemble a trajectory, sorting by stamp; stamps and images must be given for all poses or none."""
    if not T:
        raise InputError(f"{source}: no poses")
    have_stamp = [s is not None for s in stamps]
    if any(have_stamp) and not all(have_stamp):
        raise InputError(f"{source}: pose {have_stamp.index(False)} has no stamp while others do")
    have_image = [i is not None and i != "" for i in images]
    if any(have_image) and not all(have_image):
        raise InputError(f"{source}: pose {have_image.index(False)} has no image name while others do")
    Ts = np.stack(T)
    check_translations(Ts, source)
    st = None
    if all(have_stamp):
        st = np.array([check_stamp(float(s), f"{source}: pose {i}") for i, s in enumerate(stamps)])  # type: ignore[arg-type]
    ims = tuple(str(i) for i in images) if all(have_image) else None
    if st is not None:
        order = np.argsort(st, kind="stable")
        st, Ts = st[order], Ts[order]
        if ims is not None:
            ims = tuple(ims[i] for i in order)
        dup = np.flatnonzero(np.diff(st) == 0)
        if dup.size:
            raise InputError(f"{source}: two poses share the stamp {float(st[dup[0]])!r} s")
    if ims is not None and len(set(ims)) != len(ims):
        seen: set[str] = set()
        first = next(i for i in ims if i in seen or seen.add(i))  # type: ignore[func-returns-value]
        raise InputError(f"{source}: image {excerpt(first)} has two poses")
    return PoseTrajectory(Ts, st, ims, source)


# ---------------------------------------------------------------------- readers
def read_poses(source: str | Path, *, format: str | None = None, units: str = "m") -> PoseTrajectory:
    """Read poses from a TUM file, a CSV file or a JSON/YAML list.

    Parameters
    ----------
    source : path
    format : {"tum", "csv", "json"} or None (by suffix: ``.csv``, ``.json``/``.yaml``, else TUM)
    units : {"m", "mm", "cm"}, the unit of the positions in the file

    Returns
    -------
    PoseTrajectory
    """
    path = Path(source)
    fmt = format.lower() if format else _pose_format(path)
    if fmt == "tum":
        return read_tum(path, units=units)
    if fmt == "csv":
        return read_pose_csv(path, units=units)
    if fmt == "json":
        return read_pose_json(path, units=units)
    raise InputError(f"{path}: --pose-format (format): got {excerpt(format)}, expected one of {list(POSE_FORMATS)}")


def _pose_format(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return "csv"
    if suffix in (".json", ".yaml", ".yml"):
        return "json"
    return "tum"


def _scale(units: str) -> float:
    if units not in POSITION_UNITS:
        raise InputError(f"--units (units): got {excerpt(units)}, expected one of {list(POSITION_UNITS)}")
    return POSITION_UNITS[units]


def read_tum(source: str | Path, *, units: str = "m") -> PoseTrajectory:
    """Read a TUM trajectory: one pose per line, ``timestamp tx ty tz qx qy qz qw``; ``#`` comments.

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as f:
    ...     _ = f.write("# t x y z qx qy qz qw\\n1.0 0 0 0.5 0 0 0 1\\n2.0 0 0 0.6 0 0 0 1\\n")
    >>> read_tum(f.name).stamps
    array([1., 2.])
    >>> os.unlink(f.name)
    """
    path = Path(source)
    scale = _scale(units)
    T, stamps = [], []
    for lineno, line in enumerate(read_table_text(path).splitlines(), start=1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        parts = text.replace(",", " ").split()
        where = f"{path}: line {lineno}"
        if len(parts) != 8:
            raise InputError(f"{where}: {len(parts)} values, expected 8: timestamp tx ty tz qx qy qz qw")
        v = [as_float(p, f"{where}: value {i + 1}") for i, p in enumerate(parts)]
        q = check_quaternion_xyzw(v[4:8], where=f"{where}: quaternion (qx qy qz qw)")
        T.append(transform_from_position_quaternion(np.asarray(v[1:4]) * scale, q))
        stamps.append(v[0])
    return make_trajectory(T, stamps, [None] * len(T), str(path))


_POSE_COLUMNS = {
    "image": ("image", "file", "filename", "file_name", "image_name", "image_file"),
    "stamp": ("stamp", "timestamp", "time", "t", "sec", "seconds"),
    "stamp_ns": ("stamp_ns", "timestamp_ns", "time_ns", "t_ns", "nsec"),
    "x": ("x", "tx", "px", "pos_x", "position_x"),
    "y": ("y", "ty", "py", "pos_y", "position_y"),
    "z": ("z", "tz", "pz", "pos_z", "position_z"),
    "qx": ("qx", "quat_x", "orientation_x"),
    "qy": ("qy", "quat_y", "orientation_y"),
    "qz": ("qz", "quat_z", "orientation_z"),
    "qw": ("qw", "quat_w", "orientation_w"),
    "rx": ("rx",),
    "ry": ("ry",),
    "rz": ("rz",),
    "roll": ("roll",),
    "pitch": ("pitch",),
    "yaw": ("yaw",),
}


def read_pose_csv(source: str | Path, *, units: str = "m") -> PoseTrajectory:
    """Read poses from a CSV with a header.

    Columns: position ``x, y, z``; orientation as ``qx, qy, qz, qw`` (quaternion_xyzw),
    or ``rx, ry, rz`` (rotation vector, radians, as Universal Robots report the TCP),
    or ``roll, pitch, yaw`` (radians, ROS RPY: ``R = Rz(yaw) Ry(pitch) Rx(roll)``);
    optional ``image`` and ``stamp`` (seconds) or ``stamp_ns``.

    Returns
    -------
    PoseTrajectory
    """
    path = Path(source)
    scale = _scale(units)
    rows, col = read_csv_table(path, _POSE_COLUMNS, required=("x", "y", "z"))
    if all(k in col for k in ("qx", "qy", "qz", "qw")):
        rot = "quaternion"
    elif all(k in col for k in ("rx", "ry", "rz")):
        rot = "rotvec"
    elif all(k in col for k in ("roll", "pitch", "yaw")):
        rot = "rpy"
    else:
        raise InputError(f"{path}: header: needs an orientation: qx, qy, qz, qw or rx, ry, rz or roll, pitch, yaw")
    T, stamps, images = [], [], []
    for lineno, row in rows:
        where = f"{path}: line {lineno}"

        def num(k: str, row: list[str] = row, where: str = where) -> float:
            return as_float(row[col[k]], f"{where}: {k}")

        p = np.array([num("x"), num("y"), num("z")]) * scale
        if rot == "quaternion":
            q = check_quaternion_xyzw([num(k) for k in ("qx", "qy", "qz", "qw")], where=f"{where}: qx, qy, qz, qw")
            R = Rotation.from_quat(q)
        elif rot == "rotvec":
            R = Rotation.from_rotvec(check_angles([num("rx"), num("ry"), num("rz")], f"{where}: rx, ry, rz"))
        else:
            R = Rotation.from_euler("xyz", check_angles([num("roll"), num("pitch"), num("yaw")], f"{where}: roll, pitch, yaw"))
        Ti = np.eye(4)
        Ti[:3, :3] = R.as_matrix()
        Ti[:3, 3] = p
        T.append(Ti)
        if "stamp" in col and row[col["stamp"]].strip():
            stamps.append(num("stamp"))
        elif "stamp_ns" in col and row[col["stamp_ns"]].strip():
            stamps.append(num("stamp_ns") * 1e-9)
        else:
            stamps.append(None)
        images.append(row[col["image"]].strip() if "image" in col else None)
    return make_trajectory(T, stamps, images, str(path))


def read_pose_json(source: str | Path | list[Any] | dict[str, Any], *, units: str = "m") -> PoseTrajectory:
    """Read poses from JSON (or YAML): a list of 4x4 matrices or of pose objects.

    Pose objects are ``{"matrix": 4x4}`` or ``{"position": [x, y, z], "quaternion_xyzw": [...]}``,
    each with optional ``stamp`` (seconds) and ``image``. The list may be wrapped as ``{"poses": [...]}``.

    Examples
    --------
    >>> read_pose_json([np.eye(4).tolist(), np.eye(4).tolist()]).T_base_frame.shape
    (2, 4, 4)
    """
    where = "poses"
    data = source
    if isinstance(source, (str, Path)):
        where = str(source)
        data = load_structured(source)
    scale = _scale(units)
    if isinstance(data, dict) and "poses" in data:
        data = data["poses"]
    if not isinstance(data, list):
        raise InputError(f"{where}: expected a list of poses, got {type(data).__name__}")
    check_rows(len(data), where, "poses")
    T, stamps, images = [], [], []
    for i, item in enumerate(data):
        w = f"{where}: poses[{i}]"
        stamp = image = None
        if isinstance(item, dict):
            item = dict(item)
            stamp = item.pop("stamp", None)
            image = item.pop("image", None)
            if stamp is not None:
                stamp = as_float(stamp, f"{w}.stamp")
            if image is not None and not isinstance(image, str):
                raise InputError(f"{w}.image: expected a file name, got {excerpt(image)}")
            Ti = _pose_object(item, w)
        else:
            Ti = check_transform(as_array(item, w), where=w)
        Ti = Ti.copy()
        Ti[:3, 3] *= scale
        T.append(Ti)
        stamps.append(stamp)
        images.append(image)
    return make_trajectory(T, stamps, images, where)


def _pose_object(item: dict[str, Any], where: str) -> NDArray[np.float64]:
    from ..session.load import pose_from_dict

    return pose_from_dict(item, where)


# ---------------------------------------------------------------------- hand-eye
def read_hand_eye(source: str | Path | dict[str, Any] | ArrayLike, *, units: str = "m") -> NDArray[np.float64]:
    """The hand-eye calibration ``T_ee_camera`` (camera pose in the end-effector frame), shape (4, 4).

    Accepts a 4x4 matrix (list or array), ``{"matrix": 4x4}``,
    ``{"position": [x, y, z], "quaternion_xyzw": [qx, qy, qz, qw]}``,
    ``{"rotation": 3x3, "translation": [x, y, z]}`` (OpenCV ``calibrateHandEye``),
    easy_handeye's ``{"transformation": {x, y, z, qx, qy, qz, qw}}``, or a file (JSON/YAML) with one of them.

    Examples
    --------
    >>> read_hand_eye({"position": [0, 0, 0.1], "quaternion_xyzw": [0, 0, 0, 1]})[:3, 3]
    array([0. , 0. , 0.1])
    """
    where = "hand_eye"
    data: Any = source
    if isinstance(source, (str, Path)):
        where = str(source)
        data = load_structured(source)
    scale = _scale(units)
    try:
        T = _hand_eye(data)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    T = T.copy()
    T[:3, 3] *= scale
    check_translations(T, where)
    return T


def _hand_eye(data: Any) -> NDArray[np.float64]:
    if isinstance(data, dict):
        if "T_ee_camera" in data:
            return _hand_eye(data["T_ee_camera"])
        if "transformation" in data:
            t = expect_object(data["transformation"], "transformation")
            missing = [k for k in ("x", "y", "z", "qx", "qy", "qz", "qw") if k not in t]
            if missing:
                raise InputError(f"transformation.{missing[0]}: missing field (easy_handeye format x y z qx qy qz qw)")
            p = [as_float(t[k], f"transformation.{k}") for k in ("x", "y", "z")]
            q = check_quaternion_xyzw(
                [as_float(t[k], f"transformation.{k}") for k in ("qx", "qy", "qz", "qw")], where="transformation"
            )
            return transform_from_position_quaternion(p, q)
        if "rotation" in data and "translation" in data:
            T = np.eye(4)
            T[:3, :3] = as_array(data["rotation"], "rotation", shape=(3, 3))
            T[:3, 3] = as_array(data["translation"], "translation", size=3).ravel()
            return check_transform(T, where="rotation")
        from ..session.load import pose_from_dict

        return pose_from_dict(data, "(hand-eye)")
    return check_transform(as_array(data, "matrix"), where="matrix")


def T_base_camera_from_T_base_ee(T_base_ee: ArrayLike, T_ee_camera: ArrayLike) -> NDArray[np.float64]:
    """Eye-in-hand composition ``T_base_camera = T_base_ee @ T_ee_camera``.

    Parameters
    ----------
    T_base_ee : array_like, shape (..., 4, 4), end-effector poses in the base frame
    T_ee_camera : array_like, shape (4, 4), the camera in the end-effector frame (hand-eye calibration)

    Returns
    -------
    T_base_camera : ndarray, shape (..., 4, 4)

    Examples
    --------
    >>> T_ee_camera = np.eye(4); T_ee_camera[2, 3] = 0.1
    >>> float(T_base_camera_from_T_base_ee(np.eye(4), T_ee_camera)[2, 3])
    0.1
    """
    return np.asarray(T_base_ee, dtype=float) @ np.asarray(T_ee_camera, dtype=float)


def T_base_ee_from_T_base_camera(T_base_camera: ArrayLike, T_ee_camera: ArrayLike) -> NDArray[np.float64]:
    """The end-effector pose that puts the camera at ``T_base_camera`` (eye-in-hand): ``T_base_camera @ inv(T_ee_camera)``.

    The inverse of :func:`T_base_camera_from_T_base_ee`: where to send the tool for a camera pose chosen by the planner.

    Parameters
    ----------
    T_base_camera : array_like, shape (..., 4, 4), camera poses in the base frame
    T_ee_camera : array_like, shape (4, 4), the camera in the end-effector frame (hand-eye calibration)

    Returns
    -------
    T_base_ee : ndarray, shape (..., 4, 4)

    Examples
    --------
    >>> T_ee_camera = np.eye(4); T_ee_camera[2, 3] = 0.1
    >>> float(T_base_ee_from_T_base_camera(np.eye(4), T_ee_camera)[2, 3])
    -0.1
    """
    return np.asarray(T_base_camera, dtype=float) @ invert_transform(np.asarray(T_ee_camera, dtype=float))


# ---------------------------------------------------------------------- interpolation
def interpolate_poses(
    stamps: ArrayLike, T: ArrayLike, query: ArrayLike, max_gap: float
) -> tuple[NDArray[np.float64], NDArray[np.bool_], list[str | None]]:
    """Poses at the query times: linear in position, slerp in rotation.

    For each query time ``t`` the samples just before and after it are used
    when they lie within ``max_gap`` of ``t``: both -> interpolated; only
    one -> that sample's pose; none -> rejected, with the reason.

    Parameters
    ----------
    stamps : array_like, shape (N,), seconds, strictly increasing
    T : array_like, shape (N, 4, 4), poses at ``stamps``
    query : array_like, shape (M,), seconds
    max_gap : float, seconds, >= 0

    Returns
    -------
    T_query : ndarray, shape (M, 4, 4), identity where rejected
    ok : ndarray, shape (M,), bool
    reasons : list of str or None, why each rejected query was rejected

    Examples
    --------
    >>> T = np.stack([np.eye(4), np.eye(4)]); T[1, 0, 3] = 1.0
    >>> Tq, ok, _ = interpolate_poses([0.0, 1.0], T, [0.25], max_gap=1.0)
    >>> float(Tq[0, 0, 3]), bool(ok[0])
    (0.25, True)
    """
    st = np.asarray(stamps, dtype=float).ravel()
    Ts = np.asarray(T, dtype=float)
    q = np.asarray(query, dtype=float).ravel()
    max_gap = _check_pose_times(st, Ts, q, max_gap)
    n = st.size
    nxt = np.searchsorted(st, q, side="left")  # first sample >= t
    prv = np.searchsorted(st, q, side="right") - 1  # last sample <= t
    has_p, has_n = prv >= 0, nxt < n
    dp = np.where(has_p, q - st[np.clip(prv, 0, n - 1)], np.inf)
    dn = np.where(has_n, st[np.clip(nxt, 0, n - 1)] - q, np.inf)
    ok_p, ok_n = dp <= max_gap, dn <= max_gap
    out = np.broadcast_to(np.eye(4), (q.size, 4, 4)).copy()
    exact = ok_p & (dp == 0)
    out[exact] = Ts[prv[exact]]
    both = ok_p & ok_n & ~exact
    if np.any(both):
        rots = Rotation.from_matrix(Ts[:, :3, :3])
        if n >= 2:
            out[both, :3, :3] = Slerp(st, rots)(q[both]).as_matrix()
            for k in range(3):
                out[both, k, 3] = np.interp(q[both], st, Ts[:, k, 3])
    only_p = ok_p & ~ok_n & ~exact
    only_n = ok_n & ~ok_p & ~exact
    out[only_p] = Ts[prv[only_p]]
    out[only_n] = Ts[nxt[only_n]]
    ok = ok_p | ok_n
    return out, ok, _rejection_reasons(q, st, dp, dn, ok, max_gap)


def _check_pose_times(st: NDArray[np.float64], Ts: NDArray[np.float64], q: NDArray[np.float64], max_gap: Any) -> float:
    """Refuse a negative ``max_gap``, poses that do not match the stamps, and unsorted or non-finite stamps; the gap, seconds."""
    max_gap = as_float(max_gap, "--max-gap (max_gap)")
    if max_gap < 0:
        raise InputError(f"--max-gap (max_gap): got {max_gap}, expected seconds >= 0")
    if st.size == 0 or Ts.shape != (st.size, 4, 4):
        raise InputError(f"interpolate_poses: {st.size} stamps and poses of shape {Ts.shape}, expected (N, 4, 4)")
    if np.any(np.diff(st) <= 0):
        raise InputError("interpolate_poses: stamps must be strictly increasing")
    if not (np.all(np.isfinite(st)) and np.all(np.isfinite(q))):
        raise InputError("interpolate_poses: stamps must be finite")
    return max_gap


def _rejection_reasons(
    q: NDArray[np.float64],
    st: NDArray[np.float64],
    dp: NDArray[np.float64],
    dn: NDArray[np.float64],
    ok: NDArray[np.bool_],
    max_gap: float,
) -> list[str | None]:
    """Why each query time got no pose (None where it got one): outside the stamps, or in a gap wider than ``max_gap``."""
    reasons: list[str | None] = []
    for i in range(q.size):
        if ok[i]:
            reasons.append(None)
        elif q[i] < st[0] or q[i] > st[-1]:
            side = "before the first" if q[i] < st[0] else "after the last"
            gap = st[0] - q[i] if q[i] < st[0] else q[i] - st[-1]
            reasons.append(f"{gap:.3g} s {side} pose, more than max_gap {max_gap:g} s")
        else:
            reasons.append(f"poses {dp[i]:.3g} s before and {dn[i]:.3g} s after, both more than max_gap {max_gap:g} s")
    return reasons


__all__ = [
    "POSE_FORMATS",
    "POSITION_UNITS",
    "PoseTrajectory",
    "T_base_camera_from_T_base_ee",
    "T_base_ee_from_T_base_camera",
    "interpolate_poses",
    "read_hand_eye",
    "read_pose_csv",
    "read_pose_json",
    "read_poses",
    "read_tum",
]
