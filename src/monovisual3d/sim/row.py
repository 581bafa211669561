"""A plant row: many fruit spread along a row, seen by a camera moving along it.

A monitoring robot scans a row, not a single truss: 50-100 fruit in view is
normal. :func:`row_scene` spreads ``n_fruit`` spheres of 20-40 mm radius
without overlap over a box of ``length`` (along base y, the row) x ``height``
(base z) x ``depth`` (base x, away from the camera), 1.2 x 0.7 x 0.25 m by
default, centred on the target. :func:`row_poses` puts ``n`` cameras on a line
parallel to the row at ``distance`` (0.8 m) in front of the row's centre plane,
spread evenly over the row's length, all looking straight at the row (base +x),
as a camera on a robot driving along it. :func:`row_camera` is the wide
1280 x 720 camera of these scenes.

The scene stores its target, length and the box that holds every fruit
(``metadata["workspace"]``, the row's box grown by the largest radius) so that
the session written from it can state the workspace.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..checks import is_int
from ..errors import InputError
from .scene import Scene, Sphere
from .viewpoints import DEFAULT_TARGET, ROW_DISTANCE_M, ROW_LENGTH_M, row_poses

#: Size of the row's box vertically (base z) and in depth (base x), metres (its length: ``ROW_LENGTH_M``).
ROW_HEIGHT_M, ROW_DEPTH_M = 0.7, 0.25
#: Fruit radius range of the row (metres).
ROW_RADIUS_RANGE = (0.02, 0.04)
#: The row camera: image size (pixels) and horizontal field of view (degrees).
ROW_IMAGE_SIZE, ROW_HFOV_DEG = (1280, 720), 90.0
#: Smallest surface-to-surface gap between two fruit, metres.
ROW_MIN_GAP_M = 0.003
#: Candidate centres drawn per fruit before the placement gives up.
TRIES_PER_FRUIT = 2000
#: Fruit per cubic metre of the row's box at most (about a third of it filled by 30 mm fruit).
MAX_FRUIT_PER_M3 = 3000.0


def row_camera() -> Camera:
    """The row scenes' camera: 1280 x 720 pixels, 90 degrees horizontal field of view."""
    return Camera.from_hfov(ROW_IMAGE_SIZE[0], ROW_IMAGE_SIZE[1], ROW_HFOV_DEG)


def row_scene(
    n_fruit: int,
    rng: np.random.Generator | int | None = None,
    *,
    length: float = ROW_LENGTH_M,
    height: float = ROW_HEIGHT_M,
    depth: float = ROW_DEPTH_M,
    target: ArrayLike = DEFAULT_TARGET,
    radius_range: tuple[float, float] = ROW_RADIUS_RANGE,
) -> Scene:
    """``n_fruit`` non-overlapping spheres inside a row's box (see the module docstring).

    Parameters
    ----------
    n_fruit : int, number of fruit
    rng : numpy Generator, seed or None
    length, height, depth : float, metres, the row's box along base y, z and x
    target : array_like, shape (3,), metres, base frame, the centre of the box
    radius_range : (min, max), metres, radii uniform in it; every fruit lies wholly inside the box

    Returns
    -------
    Scene, named ``row``

    Raises
    ------
    InputError
        A size that is not a positive number, or more fruit than fit.

    Examples
    --------
    >>> s = row_scene(20, rng=0)
    >>> len(s.fruits), bool(np.all(np.abs(s.centres[:, 1] - 0.0) + s.radii <= 0.6 + 1e-9))
    (20, True)
    """
    if not is_int(n_fruit) or n_fruit < 1:
        raise InputError(f"n_fruit: got {n_fruit!r}, expected a positive integer")
    size = np.array([depth, length, height], dtype=float)
    for name, v in zip(("depth", "length", "height"), size.tolist()):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{name}: got {v!r}, expected a positive number of metres")
    r_lo, r_hi = (float(r) for r in radius_range)
    if not (0 < r_lo <= r_hi and 2 * r_hi < size.min()):
        raise InputError(f"radius_range: got {radius_range!r}, expected 0 < min <= max < half the row's smallest size")
    if n_fruit > MAX_FRUIT_PER_M3 * float(np.prod(size)):
        raise InputError(
            f"n_fruit: got {n_fruit}, at most {int(MAX_FRUIT_PER_M3 * float(np.prod(size)))} fit a row of "
            f"{length:g} x {height:g} x {depth:g} m; use fewer fruit or a longer row"
        )
    rng = np.random.default_rng(rng)
    t = np.asarray(target, dtype=float)
    centres, radii = _place(rng, t, size / 2, (r_lo, r_hi), int(n_fruit))
    grow = r_hi + 0.02
    meta = {
        "target": t.tolist(),
        "generator": "row_scene",
        "row_length": float(length),
        "workspace": {"min": (t - size / 2 - grow).tolist(), "max": (t + size / 2 + grow).tolist()},
    }
    return Scene(tuple(Sphere(c, r) for c, r in zip(centres, radii)), (), "row", meta)


def _place(
    rng: np.random.Generator, t: NDArray[np.float64], half: NDArray[np.float64], radius_range: tuple[float, float], n: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Random sequential placement of ``n`` spheres wholly inside the box ``t +- half`` (centres (n, 3), radii (n,))."""
    centres = np.zeros((n, 3))
    radii = np.zeros(n)
    placed = 0
    for _ in range(TRIES_PER_FRUIT * n):
        if placed == n:
            break
        r = float(rng.uniform(*radius_range))
        c = t + rng.uniform(-1.0, 1.0, 3) * (half - r)
        if placed and np.any(np.linalg.norm(centres[:placed] - c, axis=1) < radii[:placed] + r + ROW_MIN_GAP_M):
            continue
        centres[placed], radii[placed] = c, r
        placed += 1
    if placed < n:
        raise InputError(f"n_fruit: placed only {placed} of {n} non-overlapping fruit in the row; use fewer or a longer row")
    return centres, radii


__all__ = ["ROW_DISTANCE_M", "ROW_LENGTH_M", "row_camera", "row_poses", "row_scene"]
