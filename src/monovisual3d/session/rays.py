"""Do box-centre rays of two views meet as one fruit would? The physical test behind the pose-convention and
swapped-box checks of :mod:`.diagnose`.

A fruit seen in two views gives two boxes whose centre rays pass close to each other (within a fraction of its
radius), in front of both cameras, at depths where the two boxes' angular sizes give the same radius. Poses in
another convention (inverted, a rotated camera frame) or boxes with x and y swapped make most rays meet behind a
camera, nowhere, or at depths where the sizes disagree. The association of boxes is not needed: a box agrees when
any box of the other view meets it so. Numpy only: part of the core.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera

#: Two views closer than this (metres) give no baseline for the ray test.
MIN_PAIR_BASELINE_M = 0.01
#: Rays closer to parallel than this (radians) are skipped: their meeting point is not determined.
MIN_RAY_ANGLE_RAD = np.radians(1.0)
#: Two box-centre rays meet when their gap is under this share of the fruit radius the boxes give at that depth ...
#: (why: docs/decisions/input-checks.md#meet_gap_radii)
MEET_GAP_RADII = 0.6
#: ... and the two radii (box angular size times depth) agree within this factor.
MEET_SIZE_RATIO = 1.6
#: Most view pairs the ray test uses (neighbours in session order first), and most boxes per view.
MAX_PAIRS = 60
MAX_BOXES_PER_VIEW = 40


def ray_agreement(camera: Camera, T_base_optical: NDArray[np.float64], boxes: Sequence[NDArray[np.float64]]) -> float | None:
    """Share of boxes whose centre ray meets a box-centre ray of another view as the same fruit would.

    For each pair of views at least :data:`MIN_PAIR_BASELINE_M` apart (neighbours in session order first, at most
    :data:`MAX_PAIRS`), a box of one view agrees when a box of the other has a centre ray that passes within
    :data:`MEET_GAP_RADII` fruit radii of it, in front of both cameras, where the two boxes' angular sizes give
    fruit radii within :data:`MEET_SIZE_RATIO` of each other. Correct poses make most boxes agree (a fruit hidden in
    the other view does not); inverted poses or a rotated camera frame make rays meet behind the cameras or nowhere.

    Parameters
    ----------
    camera : Camera
    T_base_optical : ndarray, shape (N, 4, 4)
    boxes : sequence of N arrays, shape (M_i, 4), pixels

    Returns
    -------
    float in [0, 1], or None where no pair of views with boxes has a baseline
    """
    T = np.asarray(T_base_optical, dtype=float)
    n = len(T)
    rays, sizes = _centre_rays(camera, T, boxes)
    pairs = [
        (i, i + k)
        for k in range(1, n)
        for i in range(n - k)
        if len(rays[i]) and len(rays[i + k]) and np.linalg.norm(T[i, :3, 3] - T[i + k, :3, 3]) >= MIN_PAIR_BASELINE_M
    ][:MAX_PAIRS]
    if not pairs:
        return None
    agree = total = 0
    for i, j in pairs:
        ok = _rays_meet(T[i, :3, 3], rays[i], sizes[i], T[j, :3, 3], rays[j], sizes[j])
        agree += int(ok.any(axis=1).sum()) + int(ok.any(axis=0).sum())
        total += ok.shape[0] + ok.shape[1]
    return agree / total if total else None


def boxes_meet(camera: Camera, T_base_optical: NDArray[np.float64], boxes: Sequence[NDArray[np.float64]]) -> bool:
    """Whether any box's centre ray meets a box-centre ray of another view as one fruit would (see
    :func:`ray_agreement`): could two of these boxes, from different views, be the same fruit?

    Parameters
    ----------
    camera : Camera
    T_base_optical : ndarray, shape (N, 4, 4)
    boxes : sequence of N arrays, shape (M_i, 4), pixels (a view without boxes: shape (0, 4))
    """
    T = np.asarray(T_base_optical, dtype=float)
    rays, sizes = _centre_rays(camera, T, boxes)
    n = len(T)
    for i in range(n):
        for j in range(i + 1, n):
            if len(rays[i]) and len(rays[j]) and np.linalg.norm(T[i, :3, 3] - T[j, :3, 3]) >= MIN_PAIR_BASELINE_M:
                if _rays_meet(T[i, :3, 3], rays[i], sizes[i], T[j, :3, 3], rays[j], sizes[j]).any():
                    return True
    return False


def _centre_rays(
    camera: Camera, T: NDArray[np.float64], boxes: Sequence[NDArray[np.float64]]
) -> tuple[list[NDArray[np.float64]], list[NDArray[np.float64]]]:
    """Per view, its boxes' centre rays (base frame, unit) and half-sizes (radians), at most MAX_BOXES_PER_VIEW."""
    rays, sizes = [], []
    for i in range(len(T)):
        b = np.asarray(boxes[i], dtype=float).reshape(-1, 4)[:MAX_BOXES_PER_VIEW]
        b = b[(b[:, 2] > b[:, 0]) & (b[:, 3] > b[:, 1])]
        centre = 0.5 * (b[:, :2] + b[:, 2:])
        rays.append(camera.rays(centre) @ T[i, :3, :3].T)
        sizes.append(0.25 * ((b[:, 2] - b[:, 0]) / camera.fx + (b[:, 3] - b[:, 1]) / camera.fy))  # half-size, radians
    return rays, sizes


def _rays_meet(
    P: NDArray[np.float64],
    u: NDArray[np.float64],
    ru: NDArray[np.float64],
    Q: NDArray[np.float64],
    v: NDArray[np.float64],
    rv: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """(A, B) whether ray ``P + s u[a]`` and ray ``Q + t v[b]`` meet as one fruit (see :func:`ray_agreement`)."""
    w0 = P - Q
    b = u @ v.T  # (A, B) cosines
    d = (u @ w0)[:, None]
    e = (v @ w0)[None, :]
    denom = 1.0 - b**2
    ok = denom > np.sin(MIN_RAY_ANGLE_RAD) ** 2
    denom = np.where(ok, denom, 1.0)
    s = (b * e - d) / denom
    t = (e - b * d) / denom
    gap = np.linalg.norm(w0[None, None, :] + s[..., None] * u[:, None, :] - t[..., None] * v[None, :, :], axis=-1)
    r_a, r_b = s * ru[:, None], t * rv[None, :]
    front = (s > 0) & (t > 0)
    ratio = np.where(front, r_a / np.where(r_b > 0, r_b, 1.0), 0.0)
    sized = (ratio < MEET_SIZE_RATIO) & (ratio > 1.0 / MEET_SIZE_RATIO)
    return ok & front & sized & (gap < MEET_GAP_RADII * 0.5 * (r_a + r_b))
