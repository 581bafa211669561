"""Where a shape fit to boxes starts (:func:`.fit.fit_ellipsoid_to_boxes`): a centre triangulated from the box
centres, sizes from the box sizes at its depth, and for the models with three semi-axes several yaws."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from .ellipsoid import Ellipsoid

#: Yaw starts of the models with three semi-axes (radians): such a shape is the same after a half turn, and after a
#: quarter turn with its horizontal semi-axes swapped; starts at 0 and an eighth of a turn cover that range evenly.
YAW_STARTS = (0.0, 0.25 * math.pi)
#: Semi-axis (metres) assumed for the depth of a guess from one view (a fruit-sized object).
ONE_VIEW_SIZE_M = 0.03


def fit_starts(
    camera: Camera,
    T: NDArray[np.float64],
    b: NDArray[np.float64],
    shape: str,
    up: NDArray[np.float64],
    free_orientation: bool,
    lo: float,
    hi: float,
    initial: Ellipsoid | None,
) -> list[NDArray[np.float64]]:
    """Starting parameter vectors (see :func:`.fit.fit_parameters`) of a ``shape`` fit to the boxes ``b`` (K, 4),
    pixels, seen from the poses ``T`` (K, 4, 4) (``T_base_optical``): the given ``initial`` or a triangulated guess
    (:func:`triangulated_guess`), sizes clipped to ``[lo, hi]`` metres; several yaws (:data:`YAW_STARTS`) for
    the models with three semi-axes."""
    if initial is not None:
        centre, s = initial.centre_base, np.clip(initial.semi_axes, lo, hi)
        horizontal, vertical = float(np.sqrt(s[0] * s[1])), float(s[2])
    else:
        centre, horizontal, vertical = triangulated_guess(camera, T, b, lo, hi)
    if shape == "sphere":
        return [np.r_[centre, math.log(math.sqrt(horizontal * vertical))]]
    if shape in ("spheroid", "cylinder"):
        return [np.r_[centre, math.log(horizontal), math.log(vertical), [0.0, 0.0] if free_orientation else []]]
    a, bb = math.log(horizontal * 1.1), math.log(horizontal / 1.1)
    out = []
    for yaw in YAW_STARTS:
        angle = np.array([0.0, 0.0, 0.0]) + yaw * up if free_orientation else np.array([yaw])
        out.append(np.r_[centre, a, bb, math.log(vertical), angle])
    return out


def triangulated_guess(
    camera: Camera, T: NDArray[np.float64], b: NDArray[np.float64], lo: float, hi: float
) -> tuple[NDArray[np.float64], float, float]:
    """The point (3,), metres, base frame, closest to the rays through the box centres, and the horizontal and vertical
    semi-axes, metres, that the median box width and height give at that depth (clipped to ``[lo, hi]``)."""
    ok = np.all(np.isfinite(b), axis=1)
    T, b = T[ok], b[ok]
    centres_uv = 0.5 * (b[:, :2] + b[:, 2:])
    d = np.einsum("kij,kj->ki", T[:, :3, :3], camera.rays(centres_uv))  # base frame
    o = T[:, :3, 3]
    guess = ONE_VIEW_SIZE_M
    if len(T) >= 2:
        A = np.zeros((3, 3))
        rhs = np.zeros(3)
        for di, oi in zip(d, o):
            P = np.eye(3) - np.outer(di, di)
            A += P
            rhs += P @ oi
        if np.linalg.cond(A) < 1e8:
            p = np.linalg.solve(A, rhs)
        else:
            p = o[0] + d[0] * guess * camera.fx / max(0.5 * (b[0, 2] - b[0, 0]), 1.0)
    else:
        p = o[0] + d[0] * guess * camera.fx / max(0.5 * (b[0, 2] - b[0, 0]), 1.0)
    z = np.einsum("ki,ki->k", p - o, T[:, :3, 2])  # depth along each optical axis
    z = np.where(z > 0, z, np.median(np.abs(z)) + 1e-3)
    half_w = 0.5 * (b[:, 2] - b[:, 0]) * z / camera.fx
    half_h = 0.5 * (b[:, 3] - b[:, 1]) * z / camera.fy
    horizontal = float(np.clip(np.median(half_w), lo, hi))
    vertical = float(np.clip(np.median(half_h), lo, hi))
    return p, horizontal, vertical
