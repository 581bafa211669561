"""Octree evaluation of the sparse coarse-to-fine path: point values and upper bounds of cells at any level.

Part of the kernels re-exported by :mod:`monovisual3d.methods.paper.engine.numba_kernels`; the Python driver is
:mod:`monovisual3d.methods.paper.engine.sparse`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ....kernels.flags import NJIT_OPTIONS
from ....kernels.project import project_cells, sphere_bounds
from ._interval import box_upper, pixel_bounds
from ._mixture import add_box_row, add_box_upper_row

#: Candidate cells evaluated together (vector loops) by :func:`octree_eval`.
OCTREE_CHUNK = 256


@njit(parallel=True, **NJIT_OPTIONS)
def octree_eval(
    ijk,
    scale,
    res,
    shape,
    view_lo,
    view_hi,
    packed,
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
    packed : :class:`monovisual3d.methods.paper.engine.params.PackedViews`, the views (a named tuple of arrays)
    log_cut : float, the bound stops being accumulated (left below ``log_cut``) once it falls
        under it: such cells are discarded by the caller anyway
    out_log_point : ndarray, shape (M,), float64, ``sum_v log L_v`` at the fine cell
        ``I * scale + scale // 2`` (a point of the fine lattice, so its maximum bounds the
        fine maximum from below); ``-inf`` where some ``L_v`` is zero
    out_log_upper : ndarray, shape (M,), float64, ``sum_v log max L_v`` over the fine cell
        centres of the cell (interval bound; see :func:`pixel_bounds`)
    """
    T, intr, dist_id, dist, kern_id, inv_n, box_off, box_par, box_reach, q_cut = packed
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
                        T,
                        intr,
                        dist,
                        v,
                        dist_id[v],
                        (lo0 + 0.5) * res,
                        (hi0 + 0.5) * res,
                        (lo1 + 0.5) * res,
                        (hi1 + 0.5) * res,
                        (lo2 + 0.5) * res,
                        (hi2 + 0.5) * res,
                    )
                    up = 0.0
                    for b in range(box_off[v], box_off[v + 1]):
                        ub_, _ = box_upper(kern_id[v], box_par, box_reach, b, q_cut, ok, ul, uh, vl, vh)
                        up += ub_
                    bound += np.log(min(up * inv_n[v], 1.0))
                lu[e] = bound
        for e in range(n):
            out_log_point[c0 + e] = lp[e]
            out_log_upper[c0 + e] = lu[e]
