"""Built-in scenes: the paper's six spheres, a greenhouse tomato truss, random spheres, non-spherical fruit.

All scenes stand around a target point (default
:data:`~monovisual3d.sim.viewpoints.DEFAULT_TARGET` = (0.6, 0, 0.45) m, base
frame, z up), 0.5 m in front of the first of the paper's poses, which looks
along base +x. Each scene stores its target in ``metadata["target"]`` so that
viewpoints can be generated around it (:func:`scene_target`).

Paper scene (:func:`paper_scene`): six spheres, three of 10 cm and three of 5 cm
diameter, in two rows of three in the plane facing the camera, 0.16 m apart
across and 0.16 m apart vertically, at depths (base x) between -0.05 and +0.05 m
around the target. Offsets from the target (metres, base frame: x depth, y left, z up):

====  =======  =======  =======  ===========
#     x        y        z        diameter
====  =======  =======  =======  ===========
0     +0.00    +0.16    +0.08    0.10
1     +0.04     0.00    +0.08    0.05
2     -0.03    -0.16    +0.08    0.10
3     +0.05    +0.16    -0.08    0.05
4     -0.05     0.00    -0.08    0.10
5     +0.02    -0.16    -0.08    0.05
====  =======  =======  =======  ===========

Every sphere is fully visible (no occlusion, inside the image) from the three
paper poses with the default camera (640 x 480, 69 degrees horizontal field of view).

Shape scenes (:func:`shapes_scene`, names ``peppers``, ``cucumbers``, ``apples``,
``mixed``): ellipsoidal fruit (:class:`~monovisual3d.sim.scene.EllipsoidFruit`) of the
kinds in :data:`FRUIT_KINDS`, placed without overlap in a box around the target
and redrawn until every fruit is inside the image and at least 90 % visible in
every view (by default the paper's poses). Semi-axes (metres; ``a, b`` horizontal,
``c`` along the vertical before the tilt):

=========  ==================  =====================  ========  ==========
kind       horizontal a        b / a                  c / a     tilt (deg)
=========  ==================  =====================  ========  ==========
tomato     0.025 - 0.04        1                      0.7-0.85  0-10
pepper     0.03 - 0.045        0.85 - 1               1.2-1.6   0-10
cucumber   0.018 - 0.025       1                      c = 0.08-0.10 m   0-15
apple      0.035 - 0.045       1                      0.85-0.95 0-10
plum       0.02 - 0.028        1                      1.05-1.15 0-10
=========  ==================  =====================  ========  ==========

Each fruit gets a uniform yaw about the vertical and a tilt (uniform angle up to
the kind's limit about a random horizontal axis).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..checks import is_int
from ..errors import InputError
from ..geometry.ellipsoid import Ellipsoid, ellipsoid_bbox
from ..geometry.orientation import rotation_upright
from ..geometry.quadric import projected_dual_conic
from ..geometry.sphere import sphere_bbox
from .raycast import render
from .scene import EllipsoidFruit, Leaf, Scene, Sphere, Stem
from .viewpoints import DEFAULT_TARGET, paper_poses

#: Offsets of the paper scene's sphere centres from the target (metres, base frame) and their radii.
PAPER_SPHERE_OFFSETS = np.array(
    [
        [0.00, 0.16, 0.08],
        [0.04, 0.00, 0.08],
        [-0.03, -0.16, 0.08],
        [0.05, 0.16, -0.08],
        [-0.05, 0.00, -0.08],
        [0.02, -0.16, -0.08],
    ]
)
PAPER_SPHERE_RADII = np.array([0.05, 0.025, 0.05, 0.025, 0.05, 0.025])
#: Fruit radius range of the greenhouse truss (metres).
GREENHOUSE_RADIUS_RANGE = (0.02, 0.04)
#: Leaf layouts tried for each truss before a new truss is drawn.
LEAF_DRAWS_PER_TRUSS = 10
#: Non-spherical fruit: label -> (horizontal semi-axis range (m), b/a range, c range, c is relative to a, max tilt (deg)).
FRUIT_KINDS: dict[str, tuple[tuple[float, float], tuple[float, float], tuple[float, float], bool, float]] = {
    "tomato": ((0.025, 0.04), (1.0, 1.0), (0.7, 0.85), True, 10.0),
    "pepper": ((0.03, 0.045), (0.85, 1.0), (1.2, 1.6), True, 10.0),
    "cucumber": ((0.018, 0.025), (1.0, 1.0), (0.08, 0.10), False, 15.0),
    "apple": ((0.035, 0.045), (1.0, 1.0), (0.85, 0.95), True, 10.0),
    "plum": ((0.02, 0.028), (1.0, 1.0), (1.05, 1.15), True, 10.0),
}
#: Shape scenes: name -> (fruit kinds, cycled over the fruit; default number of fruit; half extent of the box (m)).
SHAPE_SCENES: dict[str, tuple[tuple[str, ...], int, tuple[float, float, float]]] = {
    "peppers": (("pepper",), 6, (0.05, 0.2, 0.1)),
    "cucumbers": (("cucumber",), 4, (0.05, 0.2, 0.05)),
    "apples": (("apple",), 6, (0.05, 0.2, 0.1)),
    "mixed": (("tomato", "pepper", "cucumber", "apple", "plum", "tomato"), 6, (0.05, 0.2, 0.1)),
}
#: Fruit of the row scene (:mod:`.row`) when no number is given.
ROW_DEFAULT_FRUIT = 48
#: Names accepted by :func:`scene_by_name`.
SCENE_NAMES = ("paper", "greenhouse", "random", "row", *SHAPE_SCENES)


def default_camera() -> Camera:
    """The simulator's default camera: 640 x 480 pixels, 69 degrees horizontal field of view."""
    return Camera.from_hfov(640, 480, 69.0)


def scene_target(scene: Scene) -> NDArray[np.float64]:
    """The point the scene's views should look at: ``metadata["target"]``, else the fruit centroid (3,)."""
    target = scene.metadata.get("target") if isinstance(scene.metadata, dict) else None
    if target is not None:
        t = np.asarray(target, dtype=float)
        if t.shape == (3,) and np.all(np.isfinite(t)):
            return t
    if not scene.fruits:
        raise InputError("scene: no fruit and no metadata.target, cannot choose where to look")
    return scene.centres.mean(axis=0)


def paper_scene(target: ArrayLike = DEFAULT_TARGET) -> Scene:
    """The paper's simulation: six spheres of 5 and 10 cm diameter about 0.5 m in front of the camera.

    Parameters
    ----------
    target : array_like, shape (3,), metres, base frame, the centre of the arrangement

    Returns
    -------
    Scene

    Examples
    --------
    >>> s = paper_scene()
    >>> len(s.fruits), sorted(set(np.round(2 * s.radii, 3).tolist()))
    (6, [0.05, 0.1])
    """
    t = _target(target)
    fruits = tuple(Sphere(t + off, float(r)) for off, r in zip(PAPER_SPHERE_OFFSETS, PAPER_SPHERE_RADII))
    return Scene(fruits, (), "paper", {"target": t.tolist(), "generator": "paper_scene"})


def random_scene(
    n_fruit: int,
    rng: np.random.Generator | int | None = None,
    *,
    target: ArrayLike = DEFAULT_TARGET,
    half_extent: ArrayLike = (0.1, 0.2, 0.15),
    radius_range: tuple[float, float] = (0.025, 0.05),
    min_gap: float = 0.005,
    max_tries: int = 10_000,
) -> Scene:
    """Non-overlapping spheres with centres uniform in a box in front of the camera.

    One unit of thought: the scene's documented parameters make most of its length; the body draws the fruit in one pass.

    Parameters
    ----------
    n_fruit : int, number of spheres
    rng : numpy Generator, seed or None
    target : array_like, shape (3,), metres, base frame, the centre of the box
    half_extent : array_like, shape (3,), metres, half sizes of the box along base x (depth), y, z
    radius_range : (min, max), metres, radii are uniform in it
    min_gap : float, metres, smallest surface-to-surface distance between spheres
    max_tries : int, candidate centres drawn before giving up

    Returns
    -------
    Scene

    Raises
    ------
    InputError
        When the spheres do not fit (a box too small for ``n_fruit``).

    Examples
    --------
    >>> s = random_scene(4, rng=0)
    >>> d = np.linalg.norm(s.centres[:, None] - s.centres[None], axis=-1) + np.eye(4)
    >>> bool(np.all(d > s.radii[:, None] + s.radii[None]))
    True
    """
    n = _count(n_fruit, "n_fruit")
    rng = np.random.default_rng(rng)
    t = _target(target)
    half = np.asarray(half_extent, dtype=float)
    if half.shape != (3,) or not np.all(half >= 0):
        raise InputError(f"half_extent: got {half_extent!r}, expected three numbers >= 0 (metres)")
    r_lo, r_hi = _radius_range(radius_range)
    centres: list[NDArray[np.float64]] = []
    radii: list[float] = []
    for _ in range(max_tries):
        if len(centres) == n:
            break
        c = t + rng.uniform(-1.0, 1.0, 3) * half
        r = float(rng.uniform(r_lo, r_hi))
        if all(np.linalg.norm(c - c2) >= r + r2 + min_gap for c2, r2 in zip(centres, radii)):
            centres.append(c)
            radii.append(r)
    if len(centres) < n:
        raise InputError(
            f"n_fruit: placed only {len(centres)} of {n} non-overlapping spheres in the box; "
            "use fewer fruit, smaller radii or a larger half_extent"
        )
    fruits = tuple(Sphere(c, r) for c, r in zip(centres, radii))
    return Scene(fruits, (), "random", {"target": t.tolist(), "generator": "random_scene"})


def greenhouse_scene(
    rng: np.random.Generator | int | None = None,
    *,
    n_fruit: int | None = None,
    n_leaves: int | None = None,
    target: ArrayLike = DEFAULT_TARGET,
    camera: Camera | None = None,
    poses: ArrayLike | None = None,
    min_views: int = 2,
    min_visible_fraction: float = 0.3,
    max_attempts: int = 50,
) -> Scene:
    """A tomato truss: fruit clustered along a stem, leaves partly occluding some of them.

    One unit of thought: the scene's documented parameters make most of its length; the body draws the plants in one pass.

    Layout (metres, base frame, around ``target``): a vertical main stem
    (radius 6 mm) 8 cm behind the target; a truss stem (radius 3.5 mm) that
    leaves the main stem 12 cm above the target and slopes down across the view
    over about 0.3 m; ``n_fruit`` tomatoes of 2-4 cm radius that hang off the
    truss stem without overlapping (scattered up to 3 cm in depth and 7 cm across the view around it); and
    ``n_leaves`` rectangular leaflets (half sizes 4-7 cm by 2-3.5 cm), most of
    them 2-8 cm in front of a fruit facing the camera (tilted up to 45 degrees)
    so that they hide part of it, the others behind the truss.

    The leaves (then the whole truss) are re-drawn until every fruit shows at
    least ``min_visible_fraction`` of its silhouette in at least ``min_views`` of ``poses``
    (default: the paper's three poses around ``target`` seen by ``camera``).

    Parameters
    ----------
    rng : numpy Generator, seed or None
    n_fruit : int, default: uniform in 5..10
    n_leaves : int, default: uniform in 3..6
    target : array_like, shape (3,), metres, base frame
    camera : Camera, default :func:`default_camera`
    poses : array_like, shape (N, 4, 4), default :func:`~monovisual3d.sim.viewpoints.paper_poses`
    min_views : int, views in which every fruit must be visible
    min_visible_fraction : float
        Part of a fruit's unoccluded silhouette area that must be visible (in the image, not hidden) for it to count as seen.
    max_attempts : int, trusses drawn before giving up (each with up to 10 draws of the leaves)

    Returns
    -------
    Scene

    Examples
    --------
    >>> s = greenhouse_scene(rng=1)
    >>> 5 <= len(s.fruits) <= 10 and any(o.to_dict()["type"] == "leaf" for o in s.occluders)
    True
    """
    rng = np.random.default_rng(rng)
    t = _target(target)
    camera = camera or default_camera()
    P = paper_poses(t) if poses is None else np.asarray(poses, dtype=float).reshape(-1, 4, 4)
    n, n_leaf = _greenhouse_counts(rng, n_fruit, n_leaves, min_views, len(P))
    # a half-resolution camera is enough for the visibility check (4x fewer rays)
    check_cam = camera.scaled(max(camera.width // 2, 1), max(camera.height // 2, 1))
    meta = {"target": t.tolist(), "generator": "greenhouse_scene", "min_views": min_views}
    for _ in range(max_attempts):
        fruits, stems = _truss(rng, t, n)
        if fruits is None:
            continue
        full_px = _silhouette_areas(check_cam, P, fruits)
        for _ in range(LEAF_DRAWS_PER_TRUSS):
            scene = Scene(tuple(fruits), tuple(stems) + tuple(_leaves(rng, t, fruits, n_leaf)), "greenhouse", meta)
            seen = np.zeros(n, dtype=int)
            for T, full in zip(P, full_px):
                seen += render(scene, check_cam, T).visible_px >= min_visible_fraction * full
            if np.all(seen >= min_views):
                return scene
    raise InputError(
        f"greenhouse_scene: no scene in {max_attempts} attempts where every fruit is visible in {min_views} views; "
        "use fewer leaves or fewer fruit"
    )


def _greenhouse_counts(
    rng: np.random.Generator, n_fruit: int | None, n_leaves: int | None, min_views: int, n_poses: int
) -> tuple[int, int]:
    """The truss's fruit and leaf counts (drawn where not given), checked."""
    if not 1 <= min_views <= n_poses:
        raise InputError(f"min_views: got {min_views!r}, expected 1..{n_poses} (the number of poses)")
    n = _count(n_fruit, "n_fruit") if n_fruit is not None else int(rng.integers(5, 11))
    if n > 12:
        raise InputError(f"n_fruit: got {n}, a truss holds at most 12 fruit here (use random_scene for more)")
    n_leaf = int(rng.integers(3, 7)) if n_leaves is None else n_leaves
    if not is_int(n_leaf) or n_leaf < 0:
        raise InputError(f"n_leaves: got {n_leaves!r}, expected an integer >= 0")
    return n, int(n_leaf)


def _silhouette_areas(camera: Camera, poses: NDArray[np.float64], fruits: list[Any]) -> list[NDArray[np.float64]]:
    """Per view, each fruit's unoccluded area (pixels): the silhouette ellipse inscribed in its exact box."""
    centres = np.array([f.centre for f in fruits])
    radii = np.array([f.radius for f in fruits])
    out = []
    for T in poses:
        b = sphere_bbox(camera, T, centres, radii, clip=False)
        out.append(np.nan_to_num(0.25 * math.pi * (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1]), nan=np.inf))
    return out


def scene_by_name(
    name: str, rng: np.random.Generator | int | None = None, *, n_fruit: int | None = None, **options: Any
) -> Scene:
    """A built-in scene by name: ``paper``, ``greenhouse``, ``random`` (``n_fruit`` defaults to 6), ``row``
    (a plant row, :func:`monovisual3d.sim.row.row_scene`, 48 fruit by default) or a shape scene
    (``peppers``, ``cucumbers``, ``apples``, ``mixed``; :func:`shapes_scene`).

    ``n_fruit`` is refused for ``paper`` (it always has six spheres); other keyword
    options go to the scene's function.

    Examples
    --------
    >>> scene_by_name("random", rng=0, n_fruit=3).name
    'random'
    """
    if name == "paper":
        if n_fruit is not None and n_fruit != len(PAPER_SPHERE_RADII):
            raise InputError(f"n_fruit: the paper scene has {len(PAPER_SPHERE_RADII)} spheres, got {n_fruit}")
        return paper_scene(**options)
    if name == "greenhouse":
        return greenhouse_scene(rng, n_fruit=n_fruit, **options)
    if name == "random":
        return random_scene(6 if n_fruit is None else n_fruit, rng, **options)
    if name in SHAPE_SCENES:
        return shapes_scene(name, rng, n_fruit=n_fruit, **options)
    if name == "row":
        from .row import row_scene

        return row_scene(ROW_DEFAULT_FRUIT if n_fruit is None else n_fruit, rng, **options)
    raise InputError(f"scene: got {name!r}, expected one of {list(SCENE_NAMES)} or a scene JSON file")


def fruit_of_kind(
    kind: str, centre: ArrayLike, rng: np.random.Generator | int | None = None, *, up: ArrayLike = (0.0, 0.0, 1.0)
) -> EllipsoidFruit:
    """A random fruit of one of :data:`FRUIT_KINDS` at ``centre`` (3,), metres, base frame.

    Examples
    --------
    >>> f = fruit_of_kind("cucumber", [0.6, 0.0, 0.45], rng=0)
    >>> f.label, bool(f.semi_axes[2] > 3 * f.semi_axes[0])
    ('cucumber', True)
    """
    if kind not in FRUIT_KINDS:
        raise InputError(f"kind: got {kind!r}, expected one of {sorted(FRUIT_KINDS)}")
    rng = np.random.default_rng(rng)
    (a_lo, a_hi), (b_lo, b_hi), (c_lo, c_hi), relative, tilt_deg = FRUIT_KINDS[kind]
    a = float(rng.uniform(a_lo, a_hi))
    b = a * float(rng.uniform(b_lo, b_hi))
    c = float(rng.uniform(c_lo, c_hi)) * (a if relative else 1.0)
    R = rotation_upright(float(rng.uniform(0.0, 2 * math.pi)), up)
    tilt = math.radians(float(rng.uniform(0.0, tilt_deg)))
    phi = float(rng.uniform(0.0, 2 * math.pi))
    axis = math.cos(phi) * R[:, 0] + math.sin(phi) * R[:, 1]  # horizontal
    R = _axis_angle(axis, tilt) @ R
    return EllipsoidFruit.from_ellipsoid(Ellipsoid.from_rotation(centre, [a, b, c], R), kind)


def shapes_scene(
    name: str = "mixed",
    rng: np.random.Generator | int | None = None,
    *,
    n_fruit: int | None = None,
    target: ArrayLike = DEFAULT_TARGET,
    camera: Camera | None = None,
    poses: ArrayLike | None = None,
    min_visible_fraction: float = 0.9,
    min_gap: float = 0.005,
    max_attempts: int = 200,
) -> Scene:
    """Non-spherical fruit (ellipsoids) in front of the camera, each visible in every view.

    One unit of thought: the scene's documented parameters make most of its length; the body draws the fruit in one pass.

    Parameters
    ----------
    name : ``peppers``, ``cucumbers``, ``apples`` or ``mixed`` (see :data:`SHAPE_SCENES` and the module docstring)
    rng : numpy Generator, seed or None
    n_fruit : int, default 6 (4 for ``cucumbers``)
    target : array_like, shape (3,), metres, base frame, the centre of the arrangement
    camera : Camera, default :func:`default_camera`
    poses : array_like, shape (N, 4, 4), default the paper's three poses around ``target``
    min_visible_fraction : float, part of each fruit's silhouette that must be visible in every view
    min_gap : float, metres, smallest separation of the fruit (along a separating direction)
    max_attempts : int, arrangements drawn before giving up

    Returns
    -------
    Scene

    Examples
    --------
    >>> s = shapes_scene("mixed", rng=0)
    >>> sorted({f.label for f in s.fruits})
    ['apple', 'cucumber', 'pepper', 'plum', 'tomato']
    """
    if name not in SHAPE_SCENES:
        raise InputError(f"scene: got {name!r}, expected one of {sorted(SHAPE_SCENES)}")
    kinds, default_n, half = SHAPE_SCENES[name]
    n = default_n if n_fruit is None else _count(n_fruit, "n_fruit")
    if n > 12:
        raise InputError(f"n_fruit: got {n}, a shape scene holds at most 12 fruit")
    rng = np.random.default_rng(rng)
    t = _target(target)
    camera = camera or default_camera()
    P = paper_poses(t) if poses is None else np.asarray(poses, dtype=float).reshape(-1, 4, 4)
    check_cam = camera.scaled(max(camera.width // 2, 1), max(camera.height // 2, 1))
    labels = [kinds[i % len(kinds)] for i in range(n)]
    for _ in range(max_attempts):
        fruits: list[EllipsoidFruit] = []
        for label in labels:
            for _ in range(200):
                f = fruit_of_kind(label, t + rng.uniform(-1.0, 1.0, 3) * np.asarray(half), rng)
                if all(_ellipsoids_apart(f.ellipsoid, g.ellipsoid, min_gap) for g in fruits):
                    fruits.append(f)
                    break
            else:
                break
        if len(fruits) < n:
            continue
        scene = Scene(tuple(fruits), (), name, {"target": t.tolist(), "generator": "shapes_scene"})
        if _all_visible(scene, check_cam, P, min_visible_fraction):
            return scene
    raise InputError(
        f"shapes_scene: no arrangement of {n} fruit in {max_attempts} attempts where every fruit is visible in every view; "
        "use fewer fruit"
    )


# ---------------------------------------------------------------------- shape-scene helpers
def _axis_angle(axis: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    """Rotation matrix (3, 3) about a unit axis (Rodrigues)."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K


def _support(e: Ellipsoid, n: NDArray[np.float64]) -> NDArray[np.float64]:
    """Half-width of the ellipsoid along unit directions n (K, 3): sqrt(n^T M n)."""
    A = e.rotation * e.semi_axes  # R diag(s)
    return np.linalg.norm(n @ A, axis=-1)


#: Fixed directions tried as separating axes (with the centre offset and the ellipsoids' axes).
_SEPARATING_DIRECTIONS = np.random.default_rng(12345).normal(size=(64, 3))
_SEPARATING_DIRECTIONS /= np.linalg.norm(_SEPARATING_DIRECTIONS, axis=1, keepdims=True)


def _ellipsoids_apart(e1: Ellipsoid, e2: Ellipsoid, gap: float) -> bool:
    """True when a direction separates the two ellipsoids by at least ``gap`` (a sufficient test)."""
    d = e2.centre_base - e1.centre_base
    dist = float(np.linalg.norm(d))
    if dist == 0:
        return False
    n = np.concatenate([d[None] / dist, e1.rotation.T, e2.rotation.T, _SEPARATING_DIRECTIONS])
    return bool(np.any(np.abs(n @ d) - _support(e1, n) - _support(e2, n) >= gap))


def _all_visible(scene: Scene, camera: Camera, poses: NDArray[np.float64], fraction: float) -> bool:
    """Every fruit inside the image (1 px margin) and ``fraction`` of its silhouette visible, in every pose."""
    ells = [f.ellipsoid for f in scene.fruits]  # type: ignore[union-attr]
    c = np.array([e.centre_base for e in ells])
    s = np.array([e.semi_axes for e in ells])
    R = np.array([e.rotation for e in ells])
    for T in poses:
        b = ellipsoid_bbox(camera, T, c, s, R, clip=False)
        if (
            not np.all(np.isfinite(b))
            or np.any(b[:, :2] < 1)
            or np.any(b[:, 2] > camera.width - 1)
            or np.any(b[:, 3] > camera.height - 1)
        ):
            return False
        C = np.linalg.inv(projected_dual_conic(camera, T, c, s, R))  # point conics
        area = math.pi * np.abs(np.linalg.det(C)) / np.abs(np.linalg.det(C[:, :2, :2])) ** 1.5
        if np.any(render(scene, camera, T).visible_px < fraction * area):
            return False
    return True


# ---------------------------------------------------------------------- greenhouse helpers
def _truss(rng: np.random.Generator, t: NDArray[np.float64], n: int) -> tuple[list[Sphere] | None, list[Stem]]:
    """Main stem, truss stem and ``n`` non-overlapping fruit hanging off it (None if they do not fit)."""
    side = rng.choice([-1.0, 1.0])  # the truss slopes down to the left or to the right
    main_x = t[0] + 0.08
    main_y = t[1] - side * 0.15 + rng.uniform(-0.02, 0.02)
    main = Stem(np.array([main_x, main_y, t[2] - 0.35]), np.array([main_x, main_y, t[2] + 0.35]), 0.006)
    start = np.array([main_x, main_y, t[2] + 0.12])
    end = np.array([t[0] + rng.uniform(-0.02, 0.02), t[1] + side * 0.15, t[2] - 0.08 + rng.uniform(-0.03, 0.03)])
    truss = Stem(start, end, 0.0035)
    axis = (end - start) / np.linalg.norm(end - start)
    # two directions perpendicular to the truss stem, for the scatter of the fruit around it
    e1 = np.cross(axis, [0.0, 0.0, 1.0])
    e1 = e1 / np.linalg.norm(e1) if np.linalg.norm(e1) > 1e-9 else np.array([1.0, 0.0, 0.0])
    e2 = np.cross(axis, e1)
    r_lo, r_hi = GREENHOUSE_RADIUS_RANGE
    centres: list[NDArray[np.float64]] = []
    radii: list[float] = []
    for _ in range(400 * n):
        if len(centres) == n:
            break
        r = float(rng.uniform(r_lo, r_hi))
        s = rng.uniform(0.2, 1.0)  # not too close to the main stem
        phi = rng.uniform(0.0, 2 * math.pi)
        # scatter: up to 3 cm in depth (e1 is horizontal, mostly along base x), 7 cm across the view
        c = start + s * (end - start) + rng.uniform(0.0, 1.0) * (0.03 * math.cos(phi) * e1 + 0.07 * math.sin(phi) * e2)
        c[2] -= 0.5 * r  # fruit hang a little below the stem
        if all(np.linalg.norm(c - c2) >= r + r2 + 0.003 for c2, r2 in zip(centres, radii)):
            centres.append(c)
            radii.append(r)
    if len(centres) < n:
        return None, []
    return [Sphere(c, r) for c, r in zip(centres, radii)], [main, truss]


def _leaves(rng: np.random.Generator, t: NDArray[np.float64], fruits: list[Sphere], n_leaves: int) -> list[Leaf]:
    """Rectangular leaflets: mostly in front of a fruit (towards the camera, -x), some behind the truss."""
    leaves: list[Leaf] = []
    for _ in range(50 * max(n_leaves, 1)):
        if len(leaves) == n_leaves:
            break
        half = (float(rng.uniform(0.04, 0.07)), float(rng.uniform(0.02, 0.035)))
        if rng.random() < 0.75:
            fruit = fruits[int(rng.integers(len(fruits)))]
            centre = fruit.centre + np.array(
                [-(fruit.radius + rng.uniform(0.02, 0.08)), rng.uniform(-0.06, 0.06), rng.uniform(-0.06, 0.06)]
            )
        else:
            centre = t + np.array([rng.uniform(0.12, 0.2), rng.uniform(-0.2, 0.2), rng.uniform(-0.15, 0.15)])
        # normal near -x (facing the camera), tilted up to 45 degrees, random rotation in its plane
        tilt = rng.uniform(0.0, math.radians(45.0))
        az = rng.uniform(0.0, 2 * math.pi)
        normal = np.array([-math.cos(tilt), math.sin(tilt) * math.cos(az), math.sin(tilt) * math.sin(az)])
        helper = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u0 = np.cross(helper, normal)
        u0 /= np.linalg.norm(u0)
        v0 = np.cross(normal, u0)
        spin = rng.uniform(0.0, math.pi)
        u = math.cos(spin) * u0 + math.sin(spin) * v0
        v = np.cross(normal, u)
        leaf = Leaf(centre, u, v, half)
        if all(_leaf_sphere_distance(leaf, f.centre) > f.radius + 0.002 for f in fruits):
            leaves.append(leaf)
    return leaves


def _leaf_sphere_distance(leaf: Leaf, point: NDArray[np.float64]) -> float:
    """Distance from a point to the leaf rectangle (metres)."""
    q = point - leaf.centre
    a = float(np.clip(q @ leaf.axis_u, -leaf.half_size[0], leaf.half_size[0]))
    b = float(np.clip(q @ leaf.axis_v, -leaf.half_size[1], leaf.half_size[1]))
    return float(np.linalg.norm(q - a * leaf.axis_u - b * leaf.axis_v))


def _target(target: ArrayLike) -> NDArray[np.float64]:
    t = np.asarray(target, dtype=float)
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise InputError(f"target: expected [x, y, z] finite (metres), got {target!r}")
    return t


def _count(n: int, where: str) -> int:
    if not is_int(n) or n < 1:
        raise InputError(f"{where}: got {n!r}, expected a positive integer")
    return int(n)


def _radius_range(radius_range: tuple[float, float]) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in radius_range)
    except (TypeError, ValueError):
        raise InputError(f"radius_range: got {radius_range!r}, expected (min, max) metres") from None
    if not (0 < lo <= hi and math.isfinite(hi)):
        raise InputError(f"radius_range: got ({lo}, {hi}), expected 0 < min <= max (metres)")
    return lo, hi
