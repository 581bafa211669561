"""Projection of grid cells to pixels: the one compiled distortion function and the row / point projections.

Shared by the methods: every compiled kernel of the package (the ``paper`` engine and the ``bayes`` kernels)
distorts through :func:`distort_xy`, whose model ids and coefficient layout are
:data:`monovisual3d.camera.DISTORTION_IDS` and :meth:`monovisual3d.camera.Camera.packed`. The numpy reference is
:meth:`monovisual3d.camera.Camera.project` (tested against these in ``tests/kernels/test_project.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .flags import NJIT_OPTIONS
from .jit import listen, load_cached_lazily

listen()  # every method's kernels project through here: their first compilation shows itself (:mod:`.jit`)
load_cached_lazily()  # and cached kernels load without numba's compile-time registries (:mod:`.jit`)

#: Pixel coordinate given to cells behind the camera: no box reaches it.
FAR_PX = 1e30

_F = np.float32


# ---------------------------------------------------------------------- distortion
@njit(inline="always", **NJIT_OPTIONS)
def distort_xy(x, y, model, k1, k2, p1, p2, k3, k4, k5, k6, one):  # pragma: no cover - compiled
    """Distort normalised coordinates ``(x, y)``: the one compiled copy of :func:`monovisual3d.camera.distort_normalised`.

    Parameters
    ----------
    x, y : float, normalised coordinates ``X / Z``, ``Y / Z``
    model : int, :data:`monovisual3d.camera.DISTORTION_IDS` (0 none, 1 plumb_bob, 2 rational_polynomial,
        3 equidistant)
    k1 .. k6 : float, the 8 packed coefficients of :meth:`monovisual3d.camera.Camera.packed` in order
        (``distortion[0:8]``; for equidistant its ``k1..k4`` are the first four)
    one : float, 1 in the working precision: pass ``1.0`` for float64, ``np.float32(1.0)`` for
        float32 (so that float32 rows stay float32 and vectorise on 8 lanes)

    Returns
    -------
    xd, yd : float, distorted normalised coordinates

    Inlined into every caller; with a constant ``model`` the other branches fold away, so the
    row loops stay branch free and vectorise. plumb_bob runs the rational formula with
    ``k4 = k5 = k6 = 0`` (the division is skipped).
    """
    if model == 0:
        return x, y
    two = one + one
    r2 = x * x + y * y
    if model == 3:
        r = math.sqrt(r2)
        th = math.atan(r)
        t2 = th * th
        thd = th * (one + t2 * (k1 + t2 * (k2 + t2 * (p1 + t2 * p2))))
        s = thd / r if r > 1e-12 else one
        return x * s, y * s
    radial = one + r2 * (k1 + r2 * (k2 + r2 * k3))
    if model == 2:
        radial = radial / (one + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + two * p1 * x * y + p2 * (r2 + two * x * x)
    yd = y * radial + p1 * (r2 + two * y * y) + two * p2 * x * y
    return xd, yd


@njit(inline="always", **NJIT_OPTIONS)
def distort_packed(x, y, model, dists, v):  # pragma: no cover - compiled
    """:func:`distort_xy` with the coefficients of row ``v`` of ``dists`` (V, 8), float64.

    Full array and an index: slicing per call would cost a reference count.
    """
    return distort_xy(
        x, y, model, dists[v, 0], dists[v, 1], dists[v, 2], dists[v, 3], dists[v, 4], dists[v, 5], dists[v, 6], dists[v, 7], 1.0
    )


# ---------------------------------------------------------------------- per-row evaluation
@njit(**NJIT_OPTIONS)
def project_cells(T, intr, model, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb):  # pragma: no cover - compiled
    """Pixels of ``n`` grid-frame points ``(gx, gy, gz) + res * (fi[e], fj[e], fk[e])`` into ``ub``, ``vb``.

    ``fi, fj, fk`` are cell offsets as floats (an int to float conversion per
    point would not vectorise on AVX2). ``ub``/``vb`` may be float64 or
    float32; the arithmetic is float64. Points behind the camera get
    :data:`FAR_PX`. One loop per distortion model, each calling :func:`distort_xy`
    with a literal model so that it is branch free and vectorises (the
    equidistant model calls ``atan`` and stays scalar). The loops are written out,
    not shared through a second inlined function: that nesting lost the
    vectorisation (3-4x slower rows).
    """
    bx = T[0, 0] * gx + T[0, 1] * gy + T[0, 2] * gz + T[0, 3]
    by = T[1, 0] * gx + T[1, 1] * gy + T[1, 2] * gz + T[1, 3]
    bz = T[2, 0] * gx + T[2, 1] * gy + T[2, 2] * gz + T[2, 3]
    ax = T[0, 0] * res
    ay = T[0, 1] * res
    az = T[0, 2] * res
    bxi = T[1, 0] * res
    byi = T[1, 1] * res
    bzi = T[1, 2] * res
    cxi = T[2, 0] * res
    cyi = T[2, 1] * res
    czi = T[2, 2] * res
    fx = intr[0]
    fy = intr[1]
    cx = intr[2]
    cy = intr[3]
    k1, k2, p1, p2, k3, k4, k5, k6 = d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7]
    if model == 0:
        for e in range(n):
            z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
            front = z > 0.0
            iz = 1.0 / (z if front else 1.0)
            x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
            y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
            ub[e] = fx * x + cx if front else FAR_PX
            vb[e] = fy * y + cy if front else FAR_PX
    elif model == 1:
        for e in range(n):
            z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
            front = z > 0.0
            iz = 1.0 / (z if front else 1.0)
            x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
            y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
            xd, yd = distort_xy(x, y, 1, k1, k2, p1, p2, k3, k4, k5, k6, 1.0)
            ub[e] = fx * xd + cx if front else FAR_PX
            vb[e] = fy * yd + cy if front else FAR_PX
    elif model == 2:
        for e in range(n):
            z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
            front = z > 0.0
            iz = 1.0 / (z if front else 1.0)
            x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
            y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
            xd, yd = distort_xy(x, y, 2, k1, k2, p1, p2, k3, k4, k5, k6, 1.0)
            ub[e] = fx * xd + cx if front else FAR_PX
            vb[e] = fy * yd + cy if front else FAR_PX
    else:
        for e in range(n):
            z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
            front = z > 0.0
            iz = 1.0 / (z if front else 1.0)
            x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
            y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
            xd, yd = distort_xy(x, y, 3, k1, k2, p1, p2, k3, k4, k5, k6, 1.0)
            ub[e] = fx * xd + cx if front else FAR_PX
            vb[e] = fy * yd + cy if front else FAR_PX


@njit(**NJIT_OPTIONS)
def project_cells32(T, intr, model, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb):  # pragma: no cover - compiled
    """Float32 twin of :func:`project_cells` (8 SIMD lanes) for the float32 Gaussian path.

    The corner of the tile is transformed in float64; offsets, division and
    distortion (:func:`distort_xy` in float32) run in float32 (pixel error about
    1e-4 px for cells within a metre or so). The equidistant model falls back to
    :func:`project_cells`.
    """
    if model == 3:
        project_cells(T, intr, model, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb)
    elif model == 0:
        _project_rows32(T, intr, 0, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb)
    elif model == 1:
        _project_rows32(T, intr, 1, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb)
    else:
        _project_rows32(T, intr, 2, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb)


@njit(inline="always", **NJIT_OPTIONS)
def _project_rows32(T, intr, model, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb):  # pragma: no cover - compiled
    """The loop of :func:`project_cells32` for one (constant) distortion model, float32."""
    bx = _F(T[0, 0] * gx + T[0, 1] * gy + T[0, 2] * gz + T[0, 3])
    by = _F(T[1, 0] * gx + T[1, 1] * gy + T[1, 2] * gz + T[1, 3])
    bz = _F(T[2, 0] * gx + T[2, 1] * gy + T[2, 2] * gz + T[2, 3])
    ax = _F(T[0, 0] * res)
    ay = _F(T[0, 1] * res)
    az = _F(T[0, 2] * res)
    bxi = _F(T[1, 0] * res)
    byi = _F(T[1, 1] * res)
    bzi = _F(T[1, 2] * res)
    cxi = _F(T[2, 0] * res)
    cyi = _F(T[2, 1] * res)
    czi = _F(T[2, 2] * res)
    fx = _F(intr[0])
    fy = _F(intr[1])
    cx = _F(intr[2])
    cy = _F(intr[3])
    far = _F(FAR_PX)
    one = _F(1.0)
    zero = _F(0.0)
    k1, k2, p1, p2 = _F(d[0]), _F(d[1]), _F(d[2]), _F(d[3])
    k3, k4, k5, k6 = _F(d[4]), _F(d[5]), _F(d[6]), _F(d[7])
    for e in range(n):
        z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
        front = z > zero
        iz = one / (z if front else one)
        x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
        y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
        xd, yd = distort_xy(x, y, model, k1, k2, p1, p2, k3, k4, k5, k6, one)
        ub[e] = fx * xd + cx if front else far
        vb[e] = fy * yd + cy if front else far


@njit(**NJIT_OPTIONS)
def project_point(Ts, intrs, dists, v, model, gx, gy, gz):  # pragma: no cover - compiled
    """Pixel ``(u, v)`` of one grid-frame point in view ``v``; :data:`FAR_PX` behind the camera.

    Scalar twin of :func:`project_cells` (full arrays and an index: slicing per call would cost a
    reference count).
    """
    z = Ts[v, 2, 0] * gx + Ts[v, 2, 1] * gy + Ts[v, 2, 2] * gz + Ts[v, 2, 3]
    if not z > 0.0:
        return FAR_PX, FAR_PX
    x = (Ts[v, 0, 0] * gx + Ts[v, 0, 1] * gy + Ts[v, 0, 2] * gz + Ts[v, 0, 3]) / z
    y = (Ts[v, 1, 0] * gx + Ts[v, 1, 1] * gy + Ts[v, 1, 2] * gz + Ts[v, 1, 3]) / z
    x, y = distort_packed(x, y, model, dists, v)
    return intrs[v, 0] * x + intrs[v, 2], intrs[v, 1] * y + intrs[v, 3]


@njit(**NJIT_OPTIONS)
def sphere_bounds(T, intr, n, cm0, cm1, cm2, rho, uc, vc, ru, rv):  # pragma: no cover - compiled
    """Pixel centre and half extents bounding the projection of balls (no distortion; vectorised).

    A ball of radius ``rho`` around ``cm`` (grid frame) maps to points ``q + d``,
    ``|d| <= rho``, in the optical frame; with ``z_q - rho > 0`` every point has
    ``|x - x_q| <= rho * sqrt(1 + x_q**2) / (z_q - rho)`` (Cauchy-Schwarz on
    ``(d_x, d_z) . (1, -x_q)``), likewise for y. Balls reaching the camera plane
    get :data:`FAR_PX` half extents (no bound).
    """
    fx = intr[0]
    fy = intr[1]
    cx = intr[2]
    cy = intr[3]
    for e in range(n):
        X = T[0, 0] * cm0[e] + T[0, 1] * cm1[e] + T[0, 2] * cm2[e] + T[0, 3]
        Y = T[1, 0] * cm0[e] + T[1, 1] * cm1[e] + T[1, 2] * cm2[e] + T[1, 3]
        Z = T[2, 0] * cm0[e] + T[2, 1] * cm1[e] + T[2, 2] * cm2[e] + T[2, 3]
        zl = Z - rho[e]
        ok = zl > 1e-9
        iz = 1.0 / (Z if ok else 1.0)
        izl = 1.0 / (zl if ok else 1.0)
        xq = X * iz
        yq = Y * iz
        uc[e] = fx * xq + cx if ok else 0.0
        vc[e] = fy * yq + cy if ok else 0.0
        ru[e] = fx * rho[e] * math.sqrt(1.0 + xq * xq) * izl if ok else FAR_PX
        rv[e] = fy * rho[e] * math.sqrt(1.0 + yq * yq) * izl if ok else FAR_PX
