"""Compiled box predictions shared by the fused kernels: the pixel box of a sphere or a spheroid seen by the camera.

Device functions (jitted and inlined into their callers): :func:`_spheroid_box_px` is the twin of
:func:`monovisual3d.geometry.spheroid.predict_spheroid_boxes` and, for a sphere, of
:func:`monovisual3d.geometry.sphere.predict_sphere_boxes`. :mod:`._kernels` (the search's scores) and
:mod:`._residuals` (the refinement's edge residuals) both use them.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from ...kernels.project import distort_xy  # the one compiled distortion (ids and coefficients of Camera.packed)


def _distort_xy(x: float, y: float, code: int, k: NDArray[np.float64]) -> tuple[float, float]:  # pragma: no cover - jitted
    """:func:`monovisual3d.kernels.project.distort_xy` with the packed coefficients ``k`` (8,)."""
    return distort_xy(x, y, code, k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7], 1.0)


def _sphere_box_normalised(X, Y, Z, r):  # pragma: no cover - jitted
    """Normalised box (x1, y1, x2, y2), undistorted, of a sphere at optical (X, Y, Z), radius r, for Z > r.

    ``tan(phi -/+ h) = (t -/+ s) / (1 +/- t s)`` with ``t = X / Z`` and ``s = tan(h) = r / sqrt(X^2 + Z^2 - r^2)``
    (no trigonometry).
    """
    tx = X / Z
    ty = Y / Z
    r2 = r * r
    sx_ = r / math.sqrt(X * X + Z * Z - r2)
    sy_ = r / math.sqrt(Y * Y + Z * Z - r2)
    nx1 = (tx - sx_) / (1.0 + tx * sx_)
    nx2 = (tx + sx_) / (1.0 - tx * sx_)
    ny1 = (ty - sy_) / (1.0 + ty * sy_)
    ny2 = (ty + sy_) / (1.0 - ty * sy_)
    return nx1, ny1, nx2, ny2


def _spheroid_box_px(X, Y, Z, a, b, ux, uy, uz, fx, fy, cx, cy, code, coeffs):  # pragma: no cover - jitted
    """Pixel box of an upright spheroid (semi-axis ``a`` across the unit axis ``u``, ``b`` along it) at optical
    (X, Y, Z), for ``Z > 0`` and ``Z^2 > a^2 + (b^2 - a^2) uz^2``: as ``geometry.spheroid.predict_spheroid_boxes``;
    for ``a == b``, a sphere's box as ``geometry.sphere.predict_sphere_boxes`` (:func:`_sphere_box_normalised`).

    The tangent lines of the projected dual conic ``C* = c c^T - A``. With distortion, each edge is distorted at
    the centre's other coordinate. One distortion for both shapes: every inlined copy of :func:`_distort_xy`
    costs compile time (issue 56).
    """
    a2 = a * a
    d = b * b - a2
    if d == 0.0:
        nx1, ny1, nx2, ny2 = _sphere_box_normalised(X, Y, Z, a)
    else:
        c11 = X * X - (a2 + d * ux * ux)
        c22 = Y * Y - (a2 + d * uy * uy)
        c33 = Z * Z - (a2 + d * uz * uz)
        c13 = X * Z - d * ux * uz
        c23 = Y * Z - d * uy * uz
        qx = c13 * c13 - c11 * c33
        qy = c23 * c23 - c22 * c33
        sx_ = math.sqrt(qx) if qx > 0.0 else 0.0
        sy_ = math.sqrt(qy) if qy > 0.0 else 0.0
        nx1 = (c13 - sx_) / c33
        nx2 = (c13 + sx_) / c33
        ny1 = (c23 - sy_) / c33
        ny2 = (c23 + sy_) / c33
    if code != 0:
        tx = X / Z
        ty = Y / Z
        dx1, dx2, dy1, dy2 = nx1, nx2, ny1, ny2
        for edge in range(4):  # one inlined distortion for the four edges, not four copies (compile time, issue 56)
            x = nx1 if edge == 0 else (nx2 if edge == 1 else tx)
            y = ty if edge < 2 else (ny1 if edge == 2 else ny2)
            xd, yd = _distort_xy(x, y, code, coeffs)
            if edge == 0:
                dx1 = xd
            elif edge == 1:
                dx2 = xd
            elif edge == 2:
                dy1 = yd
            else:
                dy2 = yd
        nx1, nx2, ny1, ny2 = dx1, dx2, dy1, dy2
    return fx * nx1 + cx, fy * ny1 + cy, fx * nx2 + cx, fy * ny2 + cy


def _in_front(Z, a, b, uz):  # pragma: no cover - jitted
    """Whether the spheroid lies entirely in front of the camera (``Z > r`` for a sphere)."""
    if a == b:
        return Z > a
    return Z > 0.0 and Z * Z > a * a + (b * b - a * a) * uz * uz


def camera_arrays(camera: Camera) -> tuple[NDArray[np.float64], int, NDArray[np.float64]]:
    """``fx, fy, cx, cy, width, height`` (6,), the distortion id and the 8 coefficients of :meth:`Camera.packed`."""
    p = camera.packed()
    cam = np.concatenate([p.intrinsics, [float(p.width), float(p.height)]])
    return cam, p.distortion_id, p.distortion


_distort_xy = numba.njit(cache=True, inline="always")(_distort_xy)
_sphere_box_normalised = numba.njit(cache=True, inline="always")(_sphere_box_normalised)
_spheroid_box_px = numba.njit(cache=True, inline="always")(_spheroid_box_px)
_in_front = numba.njit(cache=True, inline="always")(_in_front)
