"""Fused, parallel numba kernels of the histogram update (the fast twin of kernels.py/filter.py).

The readable numpy reference is :func:`monovisual3d.filter.paper_view_likelihood_grid`
with :func:`monovisual3d.filter.paper_update`; tests in ``tests/engine`` compare the
two. Nothing here builds an N x 3 array of cell centres: centres come from the
cell indices inside the loops.

How the dense update works
--------------------------
The grid is cut into tiles (default 4 x 4 x 32 cells, k contiguous). For each
tile and view:

1. The tile's extreme cell centres are projected. A pinhole projection maps
   the convex hull of the tile to the convex hull of the projected corners
   (all corners in front of the camera), so the bounding rectangle of the
   corners bounds every cell of the tile in normalised coordinates. Lens
   distortion is bounded with interval arithmetic, which stays conservative
   even where the distortion polynomial folds over.
2. Each box is classified against that rectangle: *outside* its support
   (skipped, exactly zero for the square kernel, below ``gauss_eps`` for the
   Gaussian), *inside* (square kernel only: contributes exactly 1 to every
   cell) or *partial* (evaluated per cell).
3. A tile whose prior is zero is skipped; a tile no box reaches is zeroed; a
   tile covered only by inside boxes is multiplied by a constant; only the
   other tiles are evaluated per cell, in rows along k written so that LLVM
   can vectorise them (branch-free projection, a branch-free ``exp``).

The posterior multiply and the per-tile sums are done in the same pass. The
maximum normalisation of the paper (Eq. 5) cancels in the final normalisation
(``prior * L / m / sum(prior * L / m) = prior * L / sum(prior * L)``), so no
second pass over the likelihood is needed; the caller normalises lazily by
passing ``in_scale`` (linear storage: 1 / previous sum) to the next call. Per-tile partial sums are added in a fixed order, so the results do
not depend on the number of threads.

Accuracy
--------
Geometry and kernels are evaluated in float64; storage may be float32. The
Gaussian cut-off under-estimates each cell's likelihood by less than
``gauss_eps`` (see :mod:`monovisual3d.engine.params`). :func:`exp_neg` has a
relative error below 1e-12 on its range.

All kernels are compiled with ``cache=True``; the first call in a fresh
environment compiles them (tens of seconds for all type signatures), later
processes load the cache.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.extending import intrinsic

#: LLVM fast-math flags used: reassociation (vectorised reductions), contraction (FMA),
#: reciprocal and approximate functions, no signed zeros. Not ``nnan``/``ninf``: the log
#: variant stores -inf and the code relies on comparisons with it.
FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}
#: Pixel coordinate given to cells behind the camera: no box reaches it.
FAR_PX = 1e30
#: Margin (pixels) of the tile/box classification, far above float64 rounding of pixel coordinates.
CLASSIFY_MARGIN_PX = 1e-6
#: Largest argument of :func:`exp_neg` (larger q are clamped; callers cut at q_cut < 43).
EXP_NEG_MAX = 43.0

_O = {"cache": True, "fastmath": FASTMATH, "nogil": True}

# Taylor coefficients of exp(-s) around 0, s = q / 64 - 0.3375 in [-0.3375, 0.3375].
_EXP_C = math.exp(-0.3375)


@njit(**_O)
def exp_neg(q):  # pragma: no cover - compiled
    """``exp(-q)`` for ``0 <= q <= 43``, branch free, relative error < 1e-12.

    Scaling and squaring: ``exp(-q) = (exp(-0.3375) * exp(-s)) ** 64`` with
    ``s = q / 64 - 0.3375`` in ``[-0.3375, 0.3375]`` and a degree-11 Taylor
    polynomial for ``exp(-s)`` (truncation 5e-15, times 64 after the squarings).
    Written without calls so that loops using it vectorise without SVML.
    """
    s = -(q * 0.015625 - 0.3375)
    p = 2.505210838544172e-08
    p = p * s + 2.755731922398589e-07
    p = p * s + 2.7557319223985893e-06
    p = p * s + 2.48015873015873e-05
    p = p * s + 0.0001984126984126984
    p = p * s + 0.001388888888888889
    p = p * s + 0.008333333333333333
    p = p * s + 0.041666666666666664
    p = p * s + 0.16666666666666666
    p = p * s + 0.5
    p = p * s + 1.0
    p = p * s + 1.0
    y = p * _EXP_C
    y = y * y
    y = y * y
    y = y * y
    y = y * y
    y = y * y
    y = y * y
    return y


# ---------------------------------------------------------------------- interval arithmetic
@njit(**_O)
def _imul(al, ah, bl, bh):  # pragma: no cover - compiled
    p1 = al * bl
    p2 = al * bh
    p3 = ah * bl
    p4 = ah * bh
    return min(min(p1, p2), min(p3, p4)), max(max(p1, p2), max(p3, p4))


@njit(**_O)
def _isq(lo, hi):  # pragma: no cover - compiled
    if lo >= 0.0:
        return lo * lo, hi * hi
    if hi <= 0.0:
        return hi * hi, lo * lo
    return 0.0, max(lo * lo, hi * hi)


@njit(**_O)
def _iscale(c, lo, hi):  # pragma: no cover - compiled
    if c >= 0.0:
        return c * lo, c * hi
    return c * hi, c * lo


@njit(**_O)
def _ipoly(c1, c2, c3, c4, lo, hi):  # pragma: no cover - compiled
    """Interval of ``1 + t (c1 + t (c2 + t (c3 + t c4)))`` for t in [lo, hi]."""
    pl, ph = _imul(c4, c4, lo, hi)
    pl, ph = _imul(pl + c3, ph + c3, lo, hi)
    pl, ph = _imul(pl + c2, ph + c2, lo, hi)
    pl, ph = _imul(pl + c1, ph + c1, lo, hi)
    return pl + 1.0, ph + 1.0


@njit(**_O)
def distort_bounds(model, dists, v, xl, xh, yl, yh):  # pragma: no cover - compiled
    """Conservative bounds of the distorted normalised coordinates over a rectangle (coefficients ``dists[v]``).

    Returns ``(ok, xdl, xdh, ydl, ydh)``; ``ok`` is False where no finite bound
    exists (a rational model whose denominator can vanish).
    """
    if model == 0:
        return True, xl, xh, yl, yh
    x2l, x2h = _isq(xl, xh)
    y2l, y2h = _isq(yl, yh)
    r2l = x2l + y2l
    r2h = x2h + y2h
    if model == 3:
        rl = math.sqrt(r2l)
        rh = math.sqrt(r2h)
        tl = math.atan(rl)
        th = math.atan(rh)
        gl = th / rh if rh > 1e-12 else 1.0  # atan(r) / r decreases with r
        gh = tl / rl if rl > 1e-12 else 1.0
        pl, ph = _ipoly(dists[v, 0], dists[v, 1], dists[v, 2], dists[v, 3], tl * tl, th * th)
        sl, sh = _imul(gl, gh, pl, ph)
        xdl, xdh = _imul(xl, xh, sl, sh)
        ydl, ydh = _imul(yl, yh, sl, sh)
        return True, xdl, xdh, ydl, ydh
    k1 = dists[v, 0]
    k2 = dists[v, 1]
    p1 = dists[v, 2]
    p2 = dists[v, 3]
    k3 = dists[v, 4]
    radl, radh = _ipoly(k1, k2, k3, 0.0, r2l, r2h)
    if model == 2:
        dl, dh = _ipoly(dists[v, 5], dists[v, 6], dists[v, 7], 0.0, r2l, r2h)
        if dl <= 0.0:
            return False, 0.0, 0.0, 0.0, 0.0
        radl, radh = _imul(radl, radh, 1.0 / dh, 1.0 / dl)
    xyl, xyh = _imul(xl, xh, yl, yh)
    al, ah = _imul(xl, xh, radl, radh)
    bl, bh = _iscale(2.0 * p1, xyl, xyh)
    cl, ch = _iscale(p2, 3.0 * x2l + y2l, 3.0 * x2h + y2h)  # r2 + 2 x^2
    xdl = al + bl + cl
    xdh = ah + bh + ch
    al, ah = _imul(yl, yh, radl, radh)
    bl, bh = _iscale(p1, x2l + 3.0 * y2l, x2h + 3.0 * y2h)  # r2 + 2 y^2
    cl, ch = _iscale(2.0 * p2, xyl, xyh)
    return True, xdl, xdh, al + bl + cl, ah + bh + ch


@njit(**_O)
def pixel_bounds(Ts, intrs, dists, v, model, cx0, cx1, cy0, cy1, cz0, cz1):  # pragma: no cover - compiled
    """Pixel rectangle bounding the projections of all points of a grid-frame box.

    The box is ``[cx0, cx1] x [cy0, cy1] x [cz0, cz1]`` (metres, grid frame) and
    ``Ts[v]`` (3, 4) maps grid to optical (full arrays and an index: slicing
    per call would cost a reference count). Returns ``(ok, ul, uh, vl, vh)``;
    ``ok`` is False where the box reaches the camera plane (no finite bound).
    """
    X0 = Ts[v, 0, 0] * cx0 + Ts[v, 0, 1] * cy0 + Ts[v, 0, 2] * cz0 + Ts[v, 0, 3]
    Y0 = Ts[v, 1, 0] * cx0 + Ts[v, 1, 1] * cy0 + Ts[v, 1, 2] * cz0 + Ts[v, 1, 3]
    Z0 = Ts[v, 2, 0] * cx0 + Ts[v, 2, 1] * cy0 + Ts[v, 2, 2] * cz0 + Ts[v, 2, 3]
    ex = cx1 - cx0
    ey = cy1 - cy0
    ez = cz1 - cz0
    xl = np.inf
    xh = -np.inf
    yl = np.inf
    yh = -np.inf
    for c in range(8):
        a = ex if c & 1 else 0.0
        b = ey if c & 2 else 0.0
        e = ez if c & 4 else 0.0
        z = Z0 + Ts[v, 2, 0] * a + Ts[v, 2, 1] * b + Ts[v, 2, 2] * e
        if not z > 1e-9:
            return False, 0.0, 0.0, 0.0, 0.0
        iz = 1.0 / z
        x = (X0 + Ts[v, 0, 0] * a + Ts[v, 0, 1] * b + Ts[v, 0, 2] * e) * iz
        y = (Y0 + Ts[v, 1, 0] * a + Ts[v, 1, 1] * b + Ts[v, 1, 2] * e) * iz
        xl = min(xl, x)
        xh = max(xh, x)
        yl = min(yl, y)
        yh = max(yh, y)
    ok, xdl, xdh, ydl, ydh = distort_bounds(model, dists, v, xl, xh, yl, yh)
    if not ok:
        return False, 0.0, 0.0, 0.0, 0.0
    fx = intrs[v, 0]
    fy = intrs[v, 1]
    return True, fx * xdl + intrs[v, 2], fx * xdh + intrs[v, 2], fy * ydl + intrs[v, 3], fy * ydh + intrs[v, 3]


@njit(**_O)
def box_upper(kernel, pars, reaches, b, q_cut, ok, ul, uh, vl, vh):  # pragma: no cover - compiled
    """Upper bound of box ``b``'s kernel over a pixel rectangle, and whether it is exactly 1 there.

    Returns ``(upper, full)``: ``upper`` is 0 where the box cannot reach the
    rectangle (below ``gauss_eps`` for the Gaussian); ``full`` is True where
    the square kernel is 1 on the whole rectangle.
    """
    if not ok:
        return 1.0, False
    m = CLASSIFY_MARGIN_PX
    if uh < reaches[b, 0] - m or ul > reaches[b, 2] + m or vh < reaches[b, 1] - m or vl > reaches[b, 3] + m:
        return 0.0, False
    if kernel == 0:
        full = ul >= reaches[b, 0] + m and uh <= reaches[b, 2] - m and vl >= reaches[b, 1] + m and vh <= reaches[b, 3] - m
        return 1.0, full
    du2, _ = _isq(ul - pars[b, 0], uh - pars[b, 0])
    dv2, _ = _isq(vl - pars[b, 1], vh - pars[b, 1])
    q = pars[b, 2] * du2 + pars[b, 3] * dv2
    if q > q_cut:
        return 0.0, False
    return math.exp(-q), False


# ---------------------------------------------------------------------- per-row evaluation
@njit(**_O)
def project_cells(T, intr, model, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb):  # pragma: no cover - compiled
    """Pixels of ``n`` grid-frame points ``(gx, gy, gz) + res * (fi[e], fj[e], fk[e])`` into ``ub``, ``vb``.

    ``fi, fj, fk`` are cell offsets as floats (an int to float conversion per
    point would not vectorise on AVX2). ``ub``/``vb`` may be float64 or
    float32; the arithmetic is float64. Points behind the camera get
    :data:`FAR_PX`. One loop per distortion model, each branch free so that it
    vectorises (the equidistant model calls ``atan`` and stays scalar).
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
    k1 = d[0]
    k2 = d[1]
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
        p1 = d[2]
        p2 = d[3]
        k3 = d[4]
        for e in range(n):
            z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
            front = z > 0.0
            iz = 1.0 / (z if front else 1.0)
            x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
            y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
            r2 = x * x + y * y
            radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
            xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
            yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
            ub[e] = fx * xd + cx if front else FAR_PX
            vb[e] = fy * yd + cy if front else FAR_PX
    elif model == 2:
        p1 = d[2]
        p2 = d[3]
        k3 = d[4]
        k4 = d[5]
        k5 = d[6]
        k6 = d[7]
        for e in range(n):
            z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
            front = z > 0.0
            iz = 1.0 / (z if front else 1.0)
            x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
            y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
            r2 = x * x + y * y
            radial = (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)))
            xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
            yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
            ub[e] = fx * xd + cx if front else FAR_PX
            vb[e] = fy * yd + cy if front else FAR_PX
    else:
        k3 = d[2]
        k4 = d[3]
        for e in range(n):
            z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
            front = z > 0.0
            iz = 1.0 / (z if front else 1.0)
            x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
            y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
            r = math.sqrt(x * x + y * y)
            th = math.atan(r)
            t2 = th * th
            thd = th * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
            s = thd / r if r > 1e-12 else 1.0
            ub[e] = fx * x * s + cx if front else FAR_PX
            vb[e] = fy * y * s + cy if front else FAR_PX


@njit(**_O)
def project_cells32(T, intr, model, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb):  # pragma: no cover - compiled
    """Float32 twin of :func:`project_cells` (8 SIMD lanes) for the float32 Gaussian path.

    The corner of the tile is transformed in float64; offsets, division and
    distortion run in float32 (pixel error about 1e-4 px for cells within a
    metre or so). The equidistant model falls back to :func:`project_cells`.
    """
    if model == 3:
        project_cells(T, intr, model, d, gx, gy, gz, res, n, fi, fj, fk, ub, vb)
        return
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
    two = _F(2.0)
    if model == 0:
        for e in range(n):
            z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
            front = z > zero
            iz = one / (z if front else one)
            x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
            y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
            ub[e] = fx * x + cx if front else far
            vb[e] = fy * y + cy if front else far
        return
    k1 = _F(d[0])
    k2 = _F(d[1])
    p1 = _F(d[2])
    p2 = _F(d[3])
    k3 = _F(d[4])
    k4 = _F(d[5])
    k5 = _F(d[6])
    k6 = _F(d[7])
    for e in range(n):
        z = bz + fi[e] * cxi + fj[e] * cyi + fk[e] * czi
        front = z > zero
        iz = one / (z if front else one)
        x = (bx + fi[e] * ax + fj[e] * ay + fk[e] * az) * iz
        y = (by + fi[e] * bxi + fj[e] * byi + fk[e] * bzi) * iz
        r2 = x * x + y * y
        radial = (one + r2 * (k1 + r2 * (k2 + r2 * k3))) / (one + r2 * (k4 + r2 * (k5 + r2 * k6)))
        xd = x * radial + two * p1 * x * y + p2 * (r2 + two * x * x)
        yd = y * radial + p1 * (r2 + two * y * y) + two * p2 * x * y
        ub[e] = fx * xd + cx if front else far
        vb[e] = fy * yd + cy if front else far


@njit(**_O)
def add_box_row(kernel, par, q_cut, ub, vb, n, acc):  # pragma: no cover - compiled
    """``acc[t] += k(ub[t], vb[t])`` for one box, t < n, float64 (branch free)."""
    if kernel == 0:
        x1 = par[0]
        y1 = par[1]
        x2 = par[2]
        y2 = par[3]
        for t in range(n):
            u = ub[t]
            v = vb[t]
            acc[t] += 1.0 if (u >= x1) & (u <= x2) & (v >= y1) & (v <= y2) else 0.0
    else:
        cu = par[0]
        cv = par[1]
        a = par[2]
        b = par[3]
        for t in range(n):
            du = ub[t] - cu
            dv = vb[t] - cv
            q = a * du * du + b * dv * dv
            e = exp_neg(min(q, q_cut))
            acc[t] += e if q <= q_cut else 0.0


@intrinsic
def _pow2_from_biased(typingctx, f):  # pragma: no cover - compiled
    """``2**n`` from ``f = (n + 127) * 2**23`` (float32): convert to int32 and reinterpret the bits."""
    if f != types.float32:
        return None
    sig = types.float32(types.float32)

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        return builder.bitcast(builder.fptosi(args[0], ir.IntType(32)), ir.FloatType())

    return sig, codegen


_F = np.float32


@njit(**_O)
def exp_neg32(q):  # pragma: no cover - compiled
    """``exp(-q)`` in float32 for ``0 <= q <= 87`` (Cephes ``expf``), relative error < 2e-7, branch free."""
    x = -q
    n = np.floor(x * _F(1.4426950408889634) + _F(0.5))
    r = x - n * _F(0.693359375) - n * _F(-2.12194440e-4)
    p = _F(1.9875691500e-4)
    p = p * r + _F(1.3981999507e-3)
    p = p * r + _F(8.3334519073e-3)
    p = p * r + _F(4.1665795894e-2)
    p = p * r + _F(1.6666665459e-1)
    p = p * r + _F(5.0000001201e-1)
    y = p * r * r + r + _F(1.0)
    return y * _pow2_from_biased((n + _F(127.0)) * _F(8388608.0))


@njit(**_O)
def add_gauss_row32(par, q_cut, ub, vb, n, acc):  # pragma: no cover - compiled
    """Float32 twin of the Gaussian branch of :func:`add_box_row` (8 lanes on AVX2)."""
    cu = _F(par[0])
    cv = _F(par[1])
    a = _F(par[2])
    b = _F(par[3])
    qc = _F(q_cut)
    zero = _F(0.0)
    for t in range(n):
        du = ub[t] - cu
        dv = vb[t] - cv
        q = a * du * du + b * dv * dv
        e = exp_neg32(min(q, qc))
        acc[t] += e if q <= qc else zero


@njit(**_O)
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
    if model == 1 or model == 2:
        r2 = x * x + y * y
        radial = 1.0 + r2 * (dists[v, 0] + r2 * (dists[v, 1] + r2 * dists[v, 4]))
        if model == 2:
            radial = radial / (1.0 + r2 * (dists[v, 5] + r2 * (dists[v, 6] + r2 * dists[v, 7])))
        p1 = dists[v, 2]
        p2 = dists[v, 3]
        xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
        yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
        x = xd
        y = yd
    elif model == 3:
        r = math.sqrt(x * x + y * y)
        th = math.atan(r)
        t2 = th * th
        thd = th * (1.0 + t2 * (dists[v, 0] + t2 * (dists[v, 1] + t2 * (dists[v, 2] + t2 * dists[v, 3]))))
        s = thd / r if r > 1e-12 else 1.0
        x = x * s
        y = y * s
    return intrs[v, 0] * x + intrs[v, 2], intrs[v, 1] * y + intrs[v, 3]


@njit(**_O)
def box_point(kernel, pars, b, q_cut, u, v):  # pragma: no cover - compiled
    """Box ``b``'s kernel at one pixel (scalar twin of :func:`add_box_row`)."""
    if kernel == 0:
        return 1.0 if (u >= pars[b, 0]) and (u <= pars[b, 2]) and (v >= pars[b, 1]) and (v <= pars[b, 3]) else 0.0
    du = u - pars[b, 0]
    dv = v - pars[b, 1]
    q = pars[b, 2] * du * du + pars[b, 3] * dv * dv
    return math.exp(-q) if q <= q_cut else 0.0


@njit(**_O)
def mixture_point(Ts, intrs, dist_id, dists, kern_id, inv_n, box_off, box_par, q_cut, v, gx, gy, gz):  # pragma: no cover
    """The paper's mixture likelihood of view ``v`` at one grid-frame point (cut-off applied)."""
    u, w = project_point(Ts, intrs, dists, v, dist_id[v], gx, gy, gz)
    if u == FAR_PX:
        return 0.0
    acc = 0.0
    k = kern_id[v]
    for b in range(box_off[v], box_off[v + 1]):
        acc += box_point(k, box_par, b, q_cut, u, w)
    return acc * inv_n[v]


# ---------------------------------------------------------------------- dense update
@njit(inline="always", **_O)
def _cells_likelihood(vp, q_cut, v0, nv, sel, nsel, cconst, precise, gx, gy, gz, res, m, F, F32, buf, buf32):  # pragma: no cover
    """``lk = buf[3, :m] = prod_v L_v`` at the cells ``(gx, gy, gz) + res * F[:, e]`` (boxes pre-selected per view).

    ``vp`` is the tuple of view arrays of :func:`dense_update`; ``F``/``F32`` (3, m) hold the cell
    offsets in float64/float32; ``buf`` (4, m) and ``buf32`` (3, m) are scratch (u, v, acc[, lk]).
    Arguments are packed so that the call can be inlined (numba does not inline calls with more
    than 30 arguments) and costs nothing per tile.
    """
    T, intr, dist_id, dist, kern_id, inv_n, box_off, box_par, box_reach = vp
    lk = buf[3]
    for e in range(m):
        lk[e] = 1.0
    for vv in range(nv):
        v = v0 + vv
        cnt = nsel[vv]
        f = inv_n[v]
        c0 = cconst[vv]
        if cnt == 0:
            c = c0 * f
            for e in range(m):
                lk[e] *= c
        elif kern_id[v] == 1 and not precise:
            ub32 = buf32[0]
            vb32 = buf32[1]
            acc32 = buf32[2]
            project_cells32(T[v], intr[v], dist_id[v], dist[v], gx, gy, gz, res, m, F32[0], F32[1], F32[2], ub32, vb32)
            for e in range(m):
                acc32[e] = c0
            for c in range(cnt):
                add_gauss_row32(box_par[sel[vv, c]], q_cut, ub32, vb32, m, acc32)
            for e in range(m):
                lk[e] *= acc32[e] * f
        else:
            ub = buf[0]
            vb = buf[1]
            acc = buf[2]
            project_cells(T[v], intr[v], dist_id[v], dist[v], gx, gy, gz, res, m, F[0], F[1], F[2], ub, vb)
            for e in range(m):
                acc[e] = c0
            for c in range(cnt):
                add_box_row(kern_id[v], box_par[sel[vv, c]], q_cut, ub, vb, m, acc)
            for e in range(m):
                lk[e] *= acc[e] * f


@njit(**_O)
def _tile_offsets(ni, nj, nk, F, F32):  # pragma: no cover - compiled
    """Cell offsets of an ``ni x nj x nk`` tile in C order into ``F`` (3, m) float64 and ``F32`` float32."""
    e = 0
    for i in range(ni):
        for j in range(nj):
            for k in range(nk):
                F[0, e] = i
                F[1, e] = j
                F[2, e] = k
                F32[0, e] = i
                F32[1, e] = j
                F32[2, e] = k
                e += 1


@njit(inline="always", **_O)
def _tile_update(src, dst, flags, geo, res, in_scale, vp, q_cut, sel, nsel, cconst, F, F32, buf, buf32):  # pragma: no cover
    """Update one tile; returns (sum, max) as described in :func:`dense_update`.

    ``flags = (inplace, prior_one, log_space, live, precise)``,
    ``geo = (base0, nj, nk, i0, i1, j0, j1, k0, k1, tile_j, tile_k, v0, nv)``, ``vp`` the view arrays.
    The full tile is evaluated (cells past the grid's edge are computed and not written) so that
    the offsets ``F`` are the same for every tile.
    """
    inplace, prior_one, log_space, live, precise = flags
    base0, nj, nk, i0, i1, j0, j1, k0, k1, tile_j, tile_k, v0, nv = geo
    T, intr, dist_id, dist, kern_id, inv_n, box_off, box_par, box_reach = vp
    floor = -np.inf if log_space else 0.0
    nrow = k1 - k0
    live_in = live
    if live and not prior_one:
        # a tile whose prior is zero everywhere stays zero: skip the views
        any_mass = False
        for i in range(i0, i1):
            for j in range(j0, j1):
                base = base0 + (i * nj + j) * nk + k0
                for t in range(nrow):
                    if src[base + t] > floor:
                        any_mass = True
                        break
                if any_mass:
                    break
            if any_mass:
                break
        live = any_mass
    dead = not live
    all_const = True
    cprod = 1.0
    for vv in range(nv):
        if dead:
            break
        v = v0 + vv
        ok, ul, uh, vl, vh = pixel_bounds(
            T, intr, dist, v, dist_id[v],
            (i0 + 0.5) * res, (i1 - 0.5) * res, (j0 + 0.5) * res, (j1 - 0.5) * res, (k0 + 0.5) * res, (k1 - 0.5) * res,
        )  # fmt: skip
        cnt = 0
        cst = 0.0
        for b in range(box_off[v], box_off[v + 1]):
            up, full = box_upper(kern_id[v], box_par, box_reach, b, q_cut, ok, ul, uh, vl, vh)
            if up == 0.0:
                continue
            if full:
                cst += 1.0
                continue
            sel[vv, cnt] = b
            cnt += 1
        nsel[vv] = cnt
        cconst[vv] = cst
        if cnt == 0:
            if cst == 0.0:
                dead = True
            cprod *= cst * inv_n[v]
        else:
            all_const = False
    if dead:
        if not (inplace and not live_in):  # in place, a tile known dead is already zero
            for i in range(i0, i1):
                for j in range(j0, j1):
                    base = base0 + (i * nj + j) * nk + k0
                    for t in range(nrow):
                        dst[base + t] = floor
        return 0.0, floor
    lk = buf[3]
    if all_const:
        for e in range(lk.shape[0]):
            lk[e] = cprod
    else:
        _cells_likelihood(
            vp, q_cut, v0, nv, sel, nsel, cconst, precise,
            (i0 + 0.5) * res, (j0 + 0.5) * res, (k0 + 0.5) * res, res, F.shape[1], F, F32, buf, buf32,
        )  # fmt: skip
    tsum = 0.0
    tmax = floor
    for i in range(i0, i1):
        for j in range(j0, j1):
            base = base0 + (i * nj + j) * nk + k0
            e0 = ((i - i0) * tile_j + (j - j0)) * tile_k
            if log_space:
                for t in range(nrow):
                    prior = 0.0 if prior_one else src[base + t] - in_scale
                    nl = prior + np.log(lk[e0 + t])
                    dst[base + t] = nl
                    tmax = max(tmax, nl)
            else:
                # linear storage: only the sum is reduced (a max reduction does not vectorise without
                # the nnan fast-math flag); values are >= 0, so a zero sum means a zero tile
                rs = 0.0
                if prior_one:
                    for t in range(nrow):
                        p = in_scale * lk[e0 + t]
                        dst[base + t] = p
                        rs += p
                elif inplace:  # read and write through one array: LLVM then sees no aliasing and vectorises
                    for t in range(nrow):
                        p = dst[base + t] * in_scale * lk[e0 + t]
                        dst[base + t] = p
                        rs += p
                else:
                    for t in range(nrow):
                        p = src[base + t] * in_scale * lk[e0 + t]
                        dst[base + t] = p
                        rs += p
                tsum += rs
                tmax = tsum
    if log_space and tmax > -np.inf:
        for i in range(i0, i1):
            for j in range(j0, j1):
                base = base0 + (i * nj + j) * nk + k0
                rs = 0.0
                for t in range(nrow):
                    q = tmax - dst[base + t]
                    rs += exp_neg(min(q, EXP_NEG_MAX)) if q <= EXP_NEG_MAX else 0.0
                tsum += rs
    return tsum, tmax


#: Tiles handled per call of :func:`_tile_range` (a call with this many array arguments costs about
#: half a microsecond, so it is made once per group of tiles, not once per tile).
TILES_PER_TASK = 16


@njit(**_O)
def _tile_range(g0, g1, src, dst, flags, value_offsets, shapes, resolutions, in_scale, view_offsets, vp, q_cut, tile, tile_offsets,
                tile_live, tile_sum, tile_max, sel, nsel, cconst, F, F32, buf, buf32):  # pragma: no cover - compiled  # fmt: skip
    """Tiles ``g0:g1`` of :func:`dense_update` (one task: one thread, its scratch arrays)."""
    inplace, prior_one, log_space, precise = flags
    for g in range(g0, g1):
        s = np.searchsorted(tile_offsets, g, side="right") - 1
        local = g - tile_offsets[s]
        ni = shapes[s, 0]
        nj = shapes[s, 1]
        nk = shapes[s, 2]
        ntj = (nj + tile[1] - 1) // tile[1]
        ntk = (nk + tile[2] - 1) // tile[2]
        ti = local // (ntj * ntk)
        rem = local - ti * ntj * ntk
        tj = rem // ntk
        tk = rem - tj * ntk
        i0 = ti * tile[0]
        j0 = tj * tile[1]
        k0 = tk * tile[2]
        geo = (
            value_offsets[s], nj, nk, i0, min(i0 + tile[0], ni), j0, min(j0 + tile[1], nj), k0, min(k0 + tile[2], nk),
            tile[1], tile[2], view_offsets[s], view_offsets[s + 1] - view_offsets[s],
        )  # fmt: skip
        ts, tm = _tile_update(
            src, dst, (inplace, prior_one, log_space, tile_live[g], precise), geo, resolutions[s], in_scale[s], vp, q_cut,
            sel, nsel, cconst, F, F32, buf, buf32,
        )  # fmt: skip
        tile_sum[g] = ts
        tile_max[g] = tm


@njit(parallel=True, **_O)
def dense_update(
    src,
    dst,
    inplace,
    prior_one,
    value_offsets,
    shapes,
    resolutions,
    in_scale,
    log_space,
    view_offsets,
    T,
    intr,
    dist_id,
    dist,
    kern_id,
    inv_n,
    box_off,
    box_par,
    box_reach,
    q_cut,
    tile,
    tile_offsets,
    tile_live,
    tile_sum,
    tile_max,
    n_threads,
    precise,
):  # pragma: no cover - compiled
    """Fold views into dense grids: ``dst = src * in_scale * prod_v L_v`` (or the log equivalent).

    Parameters
    ----------
    src : ndarray, shape (sum of cells,), float32 or float64, all grids concatenated (C order each)
    dst : ndarray, same shape, float32 or float64; may be ``src`` itself (in place)
    inplace : bool, ``dst`` is ``src``: tiles not live are then left untouched
    prior_one : bool, ignore ``src`` and take the prior as 1 (``dst`` receives the likelihood)
    value_offsets : ndarray, shape (S,), int64, first cell of grid s in ``src``/``dst``
    shapes : ndarray, shape (S, 3), int64, grid shapes (i, j, k)
    resolutions : ndarray, shape (S,), float64, metres
    in_scale : ndarray, shape (S,), float64; linear: factor applied to the prior; log: offset subtracted
    log_space : bool, values hold log posteriors (``-inf`` for zero)
    view_offsets : ndarray, shape (S + 1,), int64, views of grid s in the packed arrays
    T .. box_reach, q_cut : the fields of :class:`monovisual3d.engine.params.PackedViews`
    tile : ndarray, shape (3,), int64, tile size
    tile_offsets : ndarray, shape (S + 1,), int64, tiles of grid s
    tile_live : ndarray, shape (n_tiles,), bool, False where the tile's prior is known to be zero
        (its ``dst`` cells are then set to zero, or ``-inf`` in log space, without reading ``src``)
    tile_sum, tile_max : ndarray, shape (n_tiles,), float64, outputs. Linear: the sum of the new
        values, in both (values are >= 0: a tile is zero exactly when its sum is). Log: the max of the
        new log values and ``sum(exp(value - max))``.
    n_threads : int, at least the largest thread id + 1 (``numba.config.NUMBA_NUM_THREADS``; passed
        in because calling ``numba.get_num_threads`` here would defeat caching)
    precise : bool, evaluate the Gaussian in float64 (else float32, 8 SIMD lanes, relative error
        about 1e-5 per cell and view; use with float32 storage)
    """
    n_tiles = tile_sum.shape[0]
    max_views = 1
    for s in range(view_offsets.shape[0] - 1):
        max_views = max(max_views, view_offsets[s + 1] - view_offsets[s])
    max_boxes = 1
    for v in range(box_off.shape[0] - 1):
        max_boxes = max(max_boxes, box_off[v + 1] - box_off[v])
    m = tile[0] * tile[1] * tile[2]
    sel = np.empty((n_threads, max_views, max_boxes), dtype=np.int64)
    nsel = np.empty((n_threads, max_views), dtype=np.int64)
    cconst = np.empty((n_threads, max_views))
    buf = np.empty((n_threads, 4, m))
    buf32 = np.empty((n_threads, 3, m), dtype=np.float32)
    F = np.empty((3, m))
    F32 = np.empty((3, m), dtype=np.float32)
    _tile_offsets(tile[0], tile[1], tile[2], F, F32)
    vp = (T, intr, dist_id, dist, kern_id, inv_n, box_off, box_par, box_reach)
    flags = (inplace, prior_one, log_space, precise)
    n_tasks = (n_tiles + TILES_PER_TASK - 1) // TILES_PER_TASK
    for c in prange(n_tasks):
        tid = numba.get_thread_id()
        _tile_range(
            c * TILES_PER_TASK, min((c + 1) * TILES_PER_TASK, n_tiles), src, dst, flags, value_offsets, shapes,
            resolutions, in_scale, view_offsets, vp, q_cut, tile, tile_offsets, tile_live, tile_sum, tile_max,
            sel[tid], nsel[tid], cconst[tid], F, F32, buf[tid], buf32[tid],
        )  # fmt: skip


@njit(parallel=True, **_O)
def scale_inplace(values, factor):  # pragma: no cover - compiled
    """``values *= factor`` in parallel (the normalisation pass)."""
    for c in prange(values.shape[0]):
        values[c] = values[c] * factor


@njit(parallel=True, **_O)
def exp_shift(values, offset, out):  # pragma: no cover - compiled
    """``out = exp(values - offset)`` (log-space state to a linear posterior)."""
    for c in prange(values.shape[0]):
        out[c] = np.exp(values[c] - offset)


# ---------------------------------------------------------------------- sparse (cells at any level)
@njit(**_O)
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


@njit(**_O)
def add_box_upper_row(kernel, par, q_cut, uc, vc, ru, rv, n, acc):  # pragma: no cover - compiled
    """``acc[e] +=`` the maximum of one box's kernel over the rectangle ``uc +- ru, vc +- rv`` (branch free)."""
    if kernel == 0:
        x1 = par[0]
        y1 = par[1]
        x2 = par[2]
        y2 = par[3]
        for e in range(n):
            hit = (uc[e] + ru[e] >= x1) & (uc[e] - ru[e] <= x2) & (vc[e] + rv[e] >= y1) & (vc[e] - rv[e] <= y2)
            acc[e] += 1.0 if hit else 0.0
    else:
        cu = par[0]
        cv = par[1]
        a = par[2]
        b = par[3]
        for e in range(n):
            du = max(abs(uc[e] - cu) - ru[e], 0.0)
            dv = max(abs(vc[e] - cv) - rv[e], 0.0)
            q = a * du * du + b * dv * dv
            e_ = exp_neg(min(q, q_cut))
            acc[e] += e_ if q <= q_cut else 0.0


#: Candidate cells evaluated together (vector loops) by :func:`octree_eval`.
OCTREE_CHUNK = 256


@njit(parallel=True, **_O)
def octree_eval(
    ijk,
    scale,
    res,
    shape,
    view_lo,
    view_hi,
    T,
    intr,
    dist_id,
    dist,
    kern_id,
    inv_n,
    box_off,
    box_par,
    box_reach,
    q_cut,
    log_cut,
    out_log_point,
    out_log_upper,
):  # pragma: no cover - compiled
    """Log-likelihood at one fine cell of each octree cell, and its upper bound over the cell.

    An octree cell ``(I, J, K)`` at ``scale = 2**level`` covers the fine cells
    ``[I * scale, (I + 1) * scale)`` (per axis, clipped to ``shape``) of a grid
    of resolution ``res``. Both outputs are sums over the views
    ``view_lo:view_hi`` of the packed arrays. Point values are computed in
    float64 with the vectorised row kernels, :data:`OCTREE_CHUNK` cells at a time.

    Parameters
    ----------
    ijk : ndarray, shape (M, 3), int32 or int64, octree cell indices
    scale : int, 2**level (1 at the fine level, where the bound equals the point value)
    res : float, fine resolution, metres
    shape : ndarray, shape (3,), int64, fine grid shape
    view_lo, view_hi : int, the views of the packed arrays to use
    T .. box_reach, q_cut : the fields of :class:`monovisual3d.engine.params.PackedViews`
    log_cut : float, the bound stops being accumulated (left below ``log_cut``) once it falls
        under it: such cells are discarded by the caller anyway
    out_log_point : ndarray, shape (M,), float64, ``sum_v log L_v`` at the fine cell
        ``I * scale + scale // 2`` (a point of the fine lattice, so its maximum bounds the
        fine maximum from below); ``-inf`` where some ``L_v`` is zero
    out_log_upper : ndarray, shape (M,), float64, ``sum_v log max L_v`` over the fine cell
        centres of the cell (interval bound; see :func:`pixel_bounds`)
    """
    m = ijk.shape[0]
    n_chunks = (m + OCTREE_CHUNK - 1) // OCTREE_CHUNK
    for ch in prange(n_chunks):
        c0 = ch * OCTREE_CHUNK
        n = min(OCTREE_CHUNK, m - c0)
        fi = np.empty(n)
        fj = np.empty(n)
        fk = np.empty(n)
        ub = np.empty(n)
        vb = np.empty(n)
        acc = np.empty(n)
        lk = np.empty(n)
        lp = np.zeros(n)
        for e in range(n):
            c = c0 + e
            fi[e] = min(ijk[c, 0] * scale + scale // 2, min(ijk[c, 0] * scale + scale, shape[0]) - 1)
            fj[e] = min(ijk[c, 1] * scale + scale // 2, min(ijk[c, 1] * scale + scale, shape[1]) - 1)
            fk[e] = min(ijk[c, 2] * scale + scale // 2, min(ijk[c, 2] * scale + scale, shape[2]) - 1)
        for e in range(n):
            lk[e] = 1.0
        for v in range(view_lo, view_hi):
            project_cells(T[v], intr[v], dist_id[v], dist[v], 0.5 * res, 0.5 * res, 0.5 * res, res, n, fi, fj, fk, ub, vb)
            for e in range(n):
                acc[e] = 0.0
            for b in range(box_off[v], box_off[v + 1]):
                add_box_row(kern_id[v], box_par[b], q_cut, ub, vb, n, acc)
            f = inv_n[v]
            for e in range(n):
                lk[e] *= acc[e] * f
            if (v - view_lo) % 16 == 15 or v == view_hi - 1:  # a product of 16 views stays above 1e-300
                for e in range(n):
                    lp[e] += np.log(lk[e])
                    lk[e] = 1.0
        if scale == 1:  # fine cells: the bound is the value
            for e in range(n):
                out_log_point[c0 + e] = lp[e]
                out_log_upper[c0 + e] = lp[e]
            continue
        # bound over each cell: views without distortion use a bounding sphere, vectorised over the
        # chunk; views with distortion the interval bound of pixel_bounds, cell by cell
        lu = np.zeros(n)
        any_dist = False
        for v in range(view_lo, view_hi):
            any_dist |= dist_id[v] != 0
        if view_hi > view_lo and not any_dist:
            cm0 = np.empty(n)
            cm1 = np.empty(n)
            cm2 = np.empty(n)
            rho = np.empty(n)
            for e in range(n):
                c = c0 + e
                a0 = (ijk[c, 0] * scale + 0.5) * res
                a1 = (ijk[c, 1] * scale + 0.5) * res
                a2 = (ijk[c, 2] * scale + 0.5) * res
                b0 = (min(ijk[c, 0] * scale + scale, shape[0]) - 0.5) * res
                b1 = (min(ijk[c, 1] * scale + scale, shape[1]) - 0.5) * res
                b2 = (min(ijk[c, 2] * scale + scale, shape[2]) - 0.5) * res
                cm0[e] = 0.5 * (a0 + b0)
                cm1[e] = 0.5 * (a1 + b1)
                cm2[e] = 0.5 * (a2 + b2)
                rho[e] = 0.5 * math.sqrt((b0 - a0) ** 2 + (b1 - a1) ** 2 + (b2 - a2) ** 2)
            for e in range(n):
                lk[e] = 1.0
            for v in range(view_lo, view_hi):
                sphere_bounds(T[v], intr[v], n, cm0, cm1, cm2, rho, ub, vb, fi, fj)
                for e in range(n):
                    acc[e] = 0.0
                for b in range(box_off[v], box_off[v + 1]):
                    add_box_upper_row(kern_id[v], box_par[b], q_cut, ub, vb, fi, fj, n, acc)
                f = inv_n[v]
                for e in range(n):
                    lk[e] *= min(acc[e] * f, 1.0)
                if (v - view_lo) % 16 == 15 or v == view_hi - 1:
                    for e in range(n):
                        lu[e] += np.log(lk[e])
                        lk[e] = 1.0
        else:
            for e in range(n):
                c = c0 + e
                lo0 = ijk[c, 0] * scale
                lo1 = ijk[c, 1] * scale
                lo2 = ijk[c, 2] * scale
                hi0 = min(lo0 + scale, shape[0]) - 1
                hi1 = min(lo1 + scale, shape[1]) - 1
                hi2 = min(lo2 + scale, shape[2]) - 1
                bound = 0.0
                for v in range(view_lo, view_hi):
                    if bound < log_cut:
                        break
                    ok, ul, uh, vl, vh = pixel_bounds(
                        T, intr, dist, v, dist_id[v],
                        (lo0 + 0.5) * res, (hi0 + 0.5) * res, (lo1 + 0.5) * res, (hi1 + 0.5) * res,
                        (lo2 + 0.5) * res, (hi2 + 0.5) * res,
                    )  # fmt: skip
                    up = 0.0
                    for b in range(box_off[v], box_off[v + 1]):
                        ub_, _ = box_upper(kern_id[v], box_par, box_reach, b, q_cut, ok, ul, uh, vl, vh)
                        up += ub_
                    bound += np.log(min(up * inv_n[v], 1.0))
                lu[e] = bound
        for e in range(n):
            out_log_point[c0 + e] = lp[e]
            out_log_upper[c0 + e] = lu[e]
