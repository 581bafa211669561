"""Interval arithmetic: conservative pixel bounds of grid-frame boxes (tiles, octree cells) and of box kernels over them.

Part of the kernels re-exported by :mod:`monovisual3d.methods.paper.engine.numba_kernels`. The bounds stay conservative even where
a distortion polynomial folds over; tests compare them with dense sampling.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ....kernels.flags import NJIT_OPTIONS
from ._common import CLASSIFY_MARGIN_PX


# ---------------------------------------------------------------------- interval arithmetic
@njit(**NJIT_OPTIONS)
def _imul(al, ah, bl, bh):  # pragma: no cover - compiled
    p1 = al * bl
    p2 = al * bh
    p3 = ah * bl
    p4 = ah * bh
    return min(min(p1, p2), min(p3, p4)), max(max(p1, p2), max(p3, p4))


@njit(**NJIT_OPTIONS)
def _isq(lo, hi):  # pragma: no cover - compiled
    if lo >= 0.0:
        return lo * lo, hi * hi
    if hi <= 0.0:
        return hi * hi, lo * lo
    return 0.0, max(lo * lo, hi * hi)


@njit(**NJIT_OPTIONS)
def _iscale(c, lo, hi):  # pragma: no cover - compiled
    if c >= 0.0:
        return c * lo, c * hi
    return c * hi, c * lo


@njit(**NJIT_OPTIONS)
def _ipoly(c1, c2, c3, c4, lo, hi):  # pragma: no cover - compiled
    """Interval of ``1 + t (c1 + t (c2 + t (c3 + t c4)))`` for t in [lo, hi]."""
    pl, ph = _imul(c4, c4, lo, hi)
    pl, ph = _imul(pl + c3, ph + c3, lo, hi)
    pl, ph = _imul(pl + c2, ph + c2, lo, hi)
    pl, ph = _imul(pl + c1, ph + c1, lo, hi)
    return pl + 1.0, ph + 1.0


@njit(**NJIT_OPTIONS)
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


@njit(**NJIT_OPTIONS)
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


@njit(**NJIT_OPTIONS)
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
