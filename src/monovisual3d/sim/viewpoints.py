"""Camera viewpoints for simulation: the paper's three poses, permutations, rings, hemispheres, arcs and rows.

Every pose is a ``T_base_optical`` (4, 4) built with :func:`monovisual3d.frames.look_at`
(the camera looks at a target with the image's "up" along base +z). The base
frame has z up; the default scenes stand around :data:`DEFAULT_TARGET`, in front
of a camera that looks along base +x (:data:`DEFAULT_VIEW_DIRECTION`).

The paper's three poses (:func:`paper_poses`), with ``d = 0.5 m`` and
``offset = 0.2 m`` (the paper gives no numbers), for a camera looking along +x
at the target ``t``:

1. straight at the fruit: camera at ``t - d * view_direction`` (for the
   defaults, ``t + (-0.5, 0, 0)``);
2. moved down and to the left (of the image) by ``offset`` each, looking up
   at ``t``: ``t + (-0.5, +0.2, -0.2)`` (base +y is the image's left);
3. moved up and to the right by ``offset`` each, looking down at ``t``:
   ``t + (-0.5, -0.2, +0.2)``.

Poses 2 and 3 are 0.57 m from the target and 29.5 degrees off the first view's
axis (22 degrees horizontally and vertically). The offset matters: with close
views the paper's method is biased in depth (the intersection of the viewing
cones is long along the view axis and wider on the far side), and the bias
grows quickly as ``offset`` shrinks and as the fruit grow.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import is_int, is_real, vector
from ..errors import InputError
from ..frames import check_transform, look_at
from ..limits import MAX_SIM_VIEWS

#: Centre of the default scenes (metres, base frame).
DEFAULT_TARGET = (0.6, 0.0, 0.45)
#: Default viewing direction (camera -> target) of the first view, base frame.
DEFAULT_VIEW_DIRECTION = (1.0, 0.0, 0.0)
#: The paper's camera-to-fruit distance and the lateral/vertical offset of poses 2 and 3 (metres).
PAPER_DISTANCE_M = 0.5
PAPER_OFFSET_M = 0.2
#: Default cone half-angle of :func:`ring_poses` and largest polar angle of :func:`hemisphere_poses`.
DEFAULT_RING_ANGLE = math.radians(20.0)
DEFAULT_HEMISPHERE_ANGLE = math.radians(60.0)
#: Default angle swept by :func:`arc_poses`, radians.
DEFAULT_ARC_SPAN = math.radians(60.0)
#: Length of the plant row of :func:`row_poses` (and of the row scene), metres.
ROW_LENGTH_M = 1.2
#: Distance from the cameras of :func:`row_poses` to the row's centre plane, metres.
ROW_DISTANCE_M = 0.8


def paper_poses(
    target: ArrayLike = DEFAULT_TARGET,
    *,
    distance: float = PAPER_DISTANCE_M,
    offset: float = PAPER_OFFSET_M,
    view_direction: ArrayLike = DEFAULT_VIEW_DIRECTION,
) -> NDArray[np.float64]:
    """The paper's three viewpoints (see the module docstring).

    Parameters
    ----------
    target : array_like, shape (3,), metres, base frame, the point all views look at
    distance : float, metres, from the first pose to the target
    offset : float, metres, lateral and vertical shift of poses 2 and 3 in the first view's image plane
    view_direction : array_like, shape (3,), base frame, direction the first view looks in

    Returns
    -------
    T_base_optical : ndarray, shape (3, 4, 4)

    Examples
    --------
    >>> P = paper_poses()
    >>> P[:, :3, 3].round(3).tolist()
    [[0.1, 0.0, 0.45], [0.1, 0.2, 0.25], [0.1, -0.2, 0.65]]
    """
    target = vector(target, 3, "target")
    _check_positive(distance, "distance")
    if not (math.isfinite(offset) and offset >= 0):
        raise InputError(f"offset: got {offset!r}, expected a number >= 0 (metres)")
    axis = _unit(view_direction, "view_direction")
    first = look_at(target - distance * axis, target)
    right, down = first[:3, 0], first[:3, 1]
    positions = [
        first[:3, 3],
        first[:3, 3] + offset * (-right + down),  # down-left: looks up at the target
        first[:3, 3] + offset * (right - down),  # up-right: looks down at the target
    ]
    return np.stack([look_at(p, target) for p in positions])


def pose_permutations(poses: ArrayLike) -> list[tuple[tuple[int, ...], NDArray[np.float64]]]:
    """All orderings of a list of poses, as the paper evaluates its three poses (3! = 6 runs).

    Parameters
    ----------
    poses : array_like, shape (N, 4, 4)

    Returns
    -------
    list of (order, poses)
        ``order`` is a tuple of indices into ``poses`` (``itertools.permutations``
        order, the identity first); ``poses`` is the reordered array, shape (N, 4, 4).

    Examples
    --------
    >>> [order for order, _ in pose_permutations(paper_poses())][:3]
    [(0, 1, 2), (0, 2, 1), (1, 0, 2)]
    """
    P = check_poses(poses)
    return [(order, P[list(order)]) for order in itertools.permutations(range(len(P)))]


def ring_poses(
    target: ArrayLike = DEFAULT_TARGET,
    n: int = 8,
    *,
    distance: float = PAPER_DISTANCE_M,
    cone_angle: float = DEFAULT_RING_ANGLE,
    view_direction: ArrayLike = DEFAULT_VIEW_DIRECTION,
    phase: float = 0.0,
) -> NDArray[np.float64]:
    """``n`` poses on a circle around the view axis, all looking at the target.

    The cameras lie on the cone of half-angle ``cone_angle`` around the axis
    through ``target`` along ``-view_direction``, at ``distance`` from the target;
    the first one is at azimuth ``phase`` (radians, 0 = the image's right of the
    axial view, counter-clockwise as the camera sees it: right, up, left, down).

    Returns
    -------
    T_base_optical : ndarray, shape (n, 4, 4)

    Examples
    --------
    >>> P = ring_poses(n=4, cone_angle=0.3)
    >>> np.linalg.norm(P[:, :3, 3] - np.array(DEFAULT_TARGET), axis=1).round(6).tolist()
    [0.5, 0.5, 0.5, 0.5]
    """
    n = _check_count(n, "n")
    _check_angle(cone_angle, "cone_angle", math.pi / 2)
    azimuth = phase + 2 * math.pi * np.arange(n) / n
    polar = np.full(n, float(cone_angle))
    return _poses_on_sphere(target, distance, view_direction, polar, azimuth)


def hemisphere_poses(
    target: ArrayLike = DEFAULT_TARGET,
    n: int = 12,
    *,
    distance: float = PAPER_DISTANCE_M,
    max_angle: float = DEFAULT_HEMISPHERE_ANGLE,
    view_direction: ArrayLike = DEFAULT_VIEW_DIRECTION,
) -> NDArray[np.float64]:
    """``n`` poses spread evenly (Fibonacci spiral) over a spherical cap facing the target.

    The cap is centred on the axis through ``target`` along ``-view_direction``
    and reaches ``max_angle`` radians from it (pi/2 = the full hemisphere); the
    first pose is on the axis. Cameras are at ``distance`` from the target and look at it.

    Returns
    -------
    T_base_optical : ndarray, shape (n, 4, 4)

    Examples
    --------
    >>> hemisphere_poses(n=5).shape
    (5, 4, 4)
    """
    n = _check_count(n, "n")
    _check_angle(max_angle, "max_angle", math.pi / 2)
    k = np.arange(n)
    # equal-area spacing on the cap: cos(polar) uniform in [cos(max_angle), 1]
    cos_polar = 1.0 - (1.0 - math.cos(max_angle)) * (k / max(n - 1, 1))
    polar = np.arccos(np.clip(cos_polar, -1.0, 1.0))
    azimuth = k * math.pi * (3.0 - math.sqrt(5.0))  # golden angle
    return _poses_on_sphere(target, distance, view_direction, polar, azimuth)


def poses_from_positions(positions: ArrayLike, target: ArrayLike = DEFAULT_TARGET) -> NDArray[np.float64]:
    """User-chosen camera positions (N, 3), metres, base frame, all looking at ``target``.

    Returns
    -------
    T_base_optical : ndarray, shape (N, 4, 4)

    Examples
    --------
    >>> poses_from_positions([[0.0, 0.0, 0.45]], [0.6, 0.0, 0.45])[0, :3, 2].round(6).tolist()
    [1.0, 0.0, 0.0]
    """
    P = np.asarray(positions, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or not np.all(np.isfinite(P)) or len(P) == 0:
        raise InputError(f"positions: expected a non-empty list of finite [x, y, z] (metres), got shape {P.shape}")
    t = vector(target, 3, "target")
    return np.stack([look_at(p, t) for p in P])


def check_poses(poses: ArrayLike) -> NDArray[np.float64]:
    """Validate a stack of rigid transforms, shape (N, 4, 4) (a single (4, 4) pose is accepted).

    Examples
    --------
    >>> check_poses(np.eye(4)).shape
    (1, 4, 4)
    """
    P = np.asarray(poses, dtype=float)
    if P.shape == (4, 4):
        P = P[None]
    if P.ndim != 3 or P.shape[1:] != (4, 4) or len(P) == 0:
        raise InputError(f"poses: expected shape (N, 4, 4) with N >= 1, got {P.shape}")
    return np.stack([check_transform(T, where=f"poses[{i}]") for i, T in enumerate(P)])


def load_poses(path: str | Path, target: ArrayLike = DEFAULT_TARGET) -> NDArray[np.float64]:
    """Poses from a JSON/YAML file.

    Accepted content: a list (or ``{"poses": [...]}``) whose items are
    ``{"position": [x, y, z], "quaternion_xyzw": [...]}`` (optical frame),
    ``{"matrix": 4x4}``, or ``{"position": [x, y, z]}`` with an optional
    ``"target": [x, y, z]`` (looks at ``target``, default the function's).

    Returns
    -------
    T_base_optical : ndarray, shape (N, 4, 4)
    """
    from .._structured import read_structured_file
    from ..session.load import pose_from_dict

    data = read_structured_file(path)
    if isinstance(data, dict) and "poses" in data:
        data = data["poses"]
    if not isinstance(data, list) or not data:
        raise InputError(f"{path}: expected a non-empty list of poses (or {{'poses': [...]}})")
    out = []
    for i, item in enumerate(data):
        where = f"{path}: poses[{i}]"
        if not isinstance(item, dict):
            raise InputError(f"{where}: expected an object, got {type(item).__name__}")
        if "matrix" in item or "quaternion_xyzw" in item:
            try:
                out.append(pose_from_dict(item, f"poses[{i}]"))
            except InputError as exc:
                raise InputError(f"{path}: {exc}") from None
        elif "position" in item:
            unknown = sorted(set(item) - {"position", "target"})
            if unknown:
                raise InputError(f"{where}.{unknown[0]}: unknown field, expected position [+ target]")
            try:
                p = vector(item["position"], 3, f"poses[{i}].position")
                t = vector(item["target"], 3, f"poses[{i}].target") if "target" in item else vector(target, 3, "target")
                out.append(look_at(p, t))
            except InputError as exc:
                raise InputError(f"{path}: {exc}") from None
        else:
            raise InputError(f"{where}: expected position + quaternion_xyzw, matrix, or position [+ target]")
    return np.stack(out)


def row_poses(
    n: int,
    target: ArrayLike = DEFAULT_TARGET,
    *,
    length: float = ROW_LENGTH_M,
    distance: float = ROW_DISTANCE_M,
    view_direction: ArrayLike = DEFAULT_VIEW_DIRECTION,
    at: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """``n`` cameras along the row, ``distance`` in front of it, spread evenly over ``length``, looking straight at it.

    The row runs along base y (the image's horizontal when ``view_direction`` is base +x). The cameras are
    the frames of one camera driven along the row at constant speed: ``at`` (continuous view positions,
    default ``0 .. n-1``) gives the camera where it is between two views or beyond the last (a pose a
    fraction of a frame late, :mod:`monovisual3d.sim.motion`).

    Returns
    -------
    T_base_optical : ndarray, shape (n, 4, 4), or (len(at), 4, 4)

    Examples
    --------
    >>> P = row_poses(3)
    >>> P[:, 1, 3].round(3).tolist(), P[0, :3, 2].round(6).tolist()
    ([0.6, 0.0, -0.6], [1.0, 0.0, 0.0])
    >>> row_poses(3, at=[0.5])[:, 1, 3].round(3).tolist()
    [0.3]
    """
    if not is_int(n) or n < 1:
        raise InputError(f"--views: got row:{n!r}, expected row:N with N >= 1 views")
    for name, v in (("--distance (distance)", distance), ("--row-length (length)", length)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{name}: got {v!r}, expected a positive number of metres")
    d = np.asarray(view_direction, dtype=float)
    d = d / np.linalg.norm(d)
    along = np.cross([0.0, 0.0, 1.0], d)  # base +y for a view along +x: the row's direction
    if not np.linalg.norm(along) > 1e-9:
        raise InputError("view_direction: must not be vertical for a row")
    along /= np.linalg.norm(along)
    t = np.asarray(target, dtype=float)
    step = length / (n - 1) if n > 1 else 0.0
    offsets = length / 2 - step * _view_positions(n, at) if n > 1 else np.zeros(len(_view_positions(n, at)))
    return np.stack([look_at(t - distance * d + s * along, t + s * along) for s in offsets])


def arc_poses(
    target: ArrayLike = DEFAULT_TARGET,
    n: int = 6,
    *,
    span: float = DEFAULT_ARC_SPAN,
    distance: float = PAPER_DISTANCE_M,
    view_direction: ArrayLike = DEFAULT_VIEW_DIRECTION,
    at: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """``n`` cameras on a horizontal arc around the target, all looking at it: a camera swept around a plant.

    The arc lies at the target's height, ``distance`` from it, and spans ``span`` radians of azimuth about
    the vertical through the target, centred on the axial view (``target - distance * view_direction``); the
    cameras go from the image's left to its right, evenly spaced. They are the frames of one camera swept at
    constant angular speed: ``at`` (continuous view positions, default ``0 .. n-1``) gives the camera where it
    is between two views or beyond the ends (a pose a fraction of a frame late, :mod:`monovisual3d.sim.motion`).

    Returns
    -------
    T_base_optical : ndarray, shape (n, 4, 4), or (len(at), 4, 4)

    Examples
    --------
    >>> P = arc_poses(n=3, span=np.radians(60.0))
    >>> np.linalg.norm(P[:, :3, 3] - np.array(DEFAULT_TARGET), axis=1).round(6).tolist()
    [0.5, 0.5, 0.5]
    >>> P[:, 1, 3].round(3).tolist()
    [0.25, 0.0, -0.25]
    """
    n = _check_count(n, "n")
    _check_angle(span, "span", 2 * math.pi)
    t = vector(target, 3, "target")
    _check_positive(distance, "distance")
    axis = _unit(view_direction, "view_direction")
    horizontal = axis - axis[2] * np.array([0.0, 0.0, 1.0])
    if not np.linalg.norm(horizontal) > 1e-9:
        raise InputError("view_direction: must not be vertical for an arc")
    horizontal /= np.linalg.norm(horizontal)
    step = span / (n - 1) if n > 1 else 0.0
    azimuth = -span / 2 + step * _view_positions(n, at) if n > 1 else np.zeros(len(_view_positions(n, at)))
    out = []
    for phi in azimuth:
        c, s = math.cos(phi), math.sin(phi)
        back = -distance * horizontal  # from the target to the axial camera
        position = t + np.array([c * back[0] - s * back[1], s * back[0] + c * back[1], 0.0])
        out.append(look_at(position, t))
    return np.stack(out)


def _view_positions(n: int, at: ArrayLike | None) -> NDArray[np.float64]:
    """Continuous view positions along a path: ``at`` (finite numbers), default ``0 .. n-1``."""
    if at is None:
        return np.arange(n, dtype=float)
    a = np.atleast_1d(np.asarray(at, dtype=float))
    if a.ndim != 1 or len(a) == 0 or not np.all(np.isfinite(a)):
        raise InputError(f"at: got {np.asarray(at).tolist()!r}, expected a non-empty list of finite view positions")
    return a


#: The ``--views`` forms that are paths a camera moves along at constant speed (they take ``at``).
PATH_VIEWS = ("arc", "row")


def poses_by_name(
    spec: str,
    target: ArrayLike = DEFAULT_TARGET,
    *,
    distance: float = PAPER_DISTANCE_M,
    view_direction: ArrayLike = DEFAULT_VIEW_DIRECTION,
    row_length: float = ROW_LENGTH_M,
    at: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Poses from a short description, as the CLI's ``--views`` takes it.

    ``paper`` (the three poses), ``ring:N[:ANGLE_DEG]`` (:func:`ring_poses`,
    default 20 degrees), ``hemisphere:N[:ANGLE_DEG]`` (:func:`hemisphere_poses`,
    default 60 degrees), ``arc:N[:SPAN_DEG]`` (:func:`arc_poses`, default 60 degrees),
    ``row:N`` (:func:`row_poses`: N cameras along a row of ``row_length`` at ``distance``),
    or the path of a pose file (:func:`load_poses`). ``at`` (continuous view positions along
    the path) is only for the paths, ``arc`` and ``row``.

    Examples
    --------
    >>> poses_by_name("ring:6").shape
    (6, 4, 4)
    >>> poses_by_name("arc:4:90", at=[0.0, 1.5]).shape
    (2, 4, 4)
    """
    spec = spec.strip()
    name, _, rest = spec.partition(":")
    _check_positive(distance, "--distance (distance)")
    if at is not None and not (name in PATH_VIEWS and rest):
        raise InputError(
            f"--views: got {spec!r}, expected views along a path (arc:N[:SPAN_DEG] or row:N) for poses between views"
        )
    if name == "paper" and not rest:
        return paper_poses(target, distance=distance, view_direction=view_direction)
    if name in ("ring", "hemisphere", "arc") and rest:
        n, angle_deg = _count_and_angle(spec, name, rest)
        if name == "ring":
            angle = math.radians(angle_deg) if angle_deg is not None else DEFAULT_RING_ANGLE
            return ring_poses(target, n, distance=distance, cone_angle=angle, view_direction=view_direction)
        if name == "arc":
            span = math.radians(angle_deg) if angle_deg is not None else DEFAULT_ARC_SPAN
            return arc_poses(target, n, span=span, distance=distance, view_direction=view_direction, at=at)
        angle = math.radians(angle_deg) if angle_deg is not None else DEFAULT_HEMISPHERE_ANGLE
        return hemisphere_poses(target, n, distance=distance, max_angle=angle, view_direction=view_direction)
    if name == "row" and rest:
        try:
            n = int(rest)
        except ValueError:
            raise InputError(f"--views: got {spec!r}, expected row:N with N an integer") from None
        return row_poses(n, target, length=row_length, distance=distance, view_direction=view_direction, at=at)
    if Path(spec).suffix.lower() in (".json", ".yaml", ".yml"):
        return load_poses(spec, target)
    raise InputError(
        f"--views: got {spec!r}, expected paper, ring:N[:ANGLE_DEG], hemisphere:N[:ANGLE_DEG], arc:N[:SPAN_DEG], row:N "
        "or a pose file (.json/.yaml)"
    )


#: Largest angle of each ``NAME:N:ANGLE_DEG`` form, degrees, and what the angle is.
_SPEC_ANGLES = {
    "ring": (90.0, "cone half-angle"),
    "hemisphere": (90.0, "largest angle from the axis"),
    "arc": (360.0, "angle swept"),
}


def _count_and_angle(spec: str, name: str, rest: str) -> tuple[int, float | None]:
    """``N`` and the optional ``ANGLE_DEG`` of ``NAME:N[:ANGLE_DEG]``, checked (one-line :class:`InputError`)."""
    parts = rest.split(":")
    try:
        n = int(parts[0])
        angle_deg = float(parts[1]) if len(parts) > 1 else None
    except ValueError:
        raise InputError(f"--views: got {spec!r}, expected {name}:N or {name}:N:ANGLE_DEG with N an integer") from None
    if len(parts) > 2:
        raise InputError(f"--views: got {spec!r}, expected {name}:N or {name}:N:ANGLE_DEG")
    if n < 1:
        raise InputError(f"--views: got {spec!r}, expected {name}:N with N >= 1 views")
    if n > MAX_SIM_VIEWS:
        raise InputError(f"--views: got {spec!r}, more than the {MAX_SIM_VIEWS} views a simulation may have")
    most, what = _SPEC_ANGLES[name]
    if angle_deg is not None and not 0.0 <= angle_deg <= most:
        raise InputError(f"--views: got {spec!r}, expected the {what} ANGLE_DEG in [0, {most:g}] degrees")
    return n, angle_deg


# ---------------------------------------------------------------------- helpers
def _poses_on_sphere(
    target: ArrayLike, distance: float, view_direction: ArrayLike, polar: NDArray, azimuth: NDArray
) -> NDArray[np.float64]:
    """Cameras at ``distance`` from ``target``, ``polar`` radians off the axis, looking at the target."""
    t = vector(target, 3, "target")
    _check_positive(distance, "distance")
    axis = _unit(view_direction, "view_direction")
    frame = look_at(t - distance * axis, t)  # the axial view: its image right/down span the azimuth plane
    right, up = frame[:3, 0], -frame[:3, 1]
    out = []
    for th, ph in zip(polar, azimuth):
        radial = math.cos(ph) * right + math.sin(ph) * up
        position = t + distance * (-math.cos(th) * axis + math.sin(th) * radial)
        out.append(look_at(position, t))
    return np.stack(out)


def _unit(v: ArrayLike, where: str) -> NDArray[np.float64]:
    a = vector(v, 3, where)
    n = float(np.linalg.norm(a))
    if n == 0:
        raise InputError(f"{where}: zero vector, expected a direction")
    return a / n


def _check_positive(value: float, where: str) -> None:
    if not is_real(value) or not (math.isfinite(value) and value > 0):
        raise InputError(f"{where}: got {value!r}, expected a positive number of metres")


def _check_count(n: int, where: str) -> int:
    if not is_int(n) or n < 1:
        raise InputError(f"{where}: got {n!r}, expected a positive integer")
    return int(n)


def _check_angle(angle: float, where: str, max_value: float) -> None:
    if not (is_real(angle) and math.isfinite(angle) and 0 <= angle <= max_value + 1e-12):
        raise InputError(f"{where}: got {angle!r} rad, expected a value in [0, {max_value:.4g}] rad")
