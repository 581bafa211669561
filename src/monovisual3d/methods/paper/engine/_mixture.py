"""The paper's box kernels (square, Gaussian) added over rows of pixels or at one point, and their upper bounds.

Part of the kernels re-exported by :mod:`monovisual3d.methods.paper.engine.numba_kernels`; the numpy reference is
:func:`monovisual3d.methods.paper.kernels.paper_view_likelihood`.
"""

from __future__ import annotations

import math

from numba import njit

from ....kernels.flags import NJIT_OPTIONS
from ....kernels.project import FAR_PX, project_point
from ._common import _F, exp_neg, exp_neg32


@njit(**NJIT_OPTIONS)
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


@njit(**NJIT_OPTIONS)
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


@njit(**NJIT_OPTIONS)
def box_point(kernel, pars, b, q_cut, u, v):  # pragma: no cover - compiled
    """Box ``b``'s kernel at one pixel (scalar twin of :func:`add_box_row`)."""
    if kernel == 0:
        return 1.0 if (u >= pars[b, 0]) and (u <= pars[b, 2]) and (v >= pars[b, 1]) and (v <= pars[b, 3]) else 0.0
    du = u - pars[b, 0]
    dv = v - pars[b, 1]
    q = pars[b, 2] * du * du + pars[b, 3] * dv * dv
    return math.exp(-q) if q <= q_cut else 0.0


@njit(**NJIT_OPTIONS)
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


@njit(**NJIT_OPTIONS)
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
