"""The fused, tiled dense update of the histogram (see :mod:`monovisual3d.methods.paper.engine.numba_kernels` for the design).

Part of the kernels re-exported by :mod:`monovisual3d.methods.paper.engine.numba_kernels`; the Python driver is
:mod:`monovisual3d.methods.paper.engine.dense`.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, prange

from ....kernels.flags import NJIT_OPTIONS
from ....kernels.project import project_cells, project_cells32
from ._common import EXP_NEG_MAX, exp_neg
from ._interval import box_upper, pixel_bounds
from ._mixture import add_box_row, add_gauss_row32


# ---------------------------------------------------------------------- dense update
@njit(inline="always", **NJIT_OPTIONS)
def _cells_likelihood(packed, v0, nv, sel, nsel, cconst, precise, gx, gy, gz, res, m, F, F32, buf, buf32):  # pragma: no cover
    """``lk = buf[3, :m] = prod_v L_v`` at the cells ``(gx, gy, gz) + res * F[:, e]`` (boxes pre-selected per view).

    ``packed`` is the :class:`~monovisual3d.methods.paper.engine.params.PackedViews` of :func:`dense_update`;
    ``F``/``F32`` (3, m) hold the cell offsets in float64/float32; ``buf`` (4, m) and ``buf32`` (3, m)
    are scratch (u, v, acc[, lk]). Arguments are packed (the views, ``flags``, ``geo``) so that the call
    can be inlined (numba does not inline calls with more than 30 arguments) and costs nothing per tile.
    """
    T, intr, dist_id, dist, kern_id, inv_n, box_off, box_par, box_reach, q_cut = packed
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


@njit(**NJIT_OPTIONS)
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


@njit(inline="always", **NJIT_OPTIONS)
def _tile_update(src, dst, flags, geo, res, in_scale, packed, sel, nsel, cconst, F, F32, buf, buf32):  # pragma: no cover
    """Update one tile; returns (sum, max) as described in :func:`dense_update`.

    ``flags = (inplace, prior_one, log_space, live, precise)``,
    ``geo = (base0, nj, nk, i0, i1, j0, j1, k0, k1, tile_j, tile_k, v0, nv)``, ``packed`` the views.
    The full tile is evaluated (cells past the grid's edge are computed and not written) so that
    the offsets ``F`` are the same for every tile.
    """
    inplace, prior_one, log_space, live, precise = flags
    base0, nj, nk, i0, i1, j0, j1, k0, k1, tile_j, tile_k, v0, nv = geo
    T, intr, dist_id, dist, kern_id, inv_n, box_off, box_par, box_reach, q_cut = packed
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
            T,
            intr,
            dist,
            v,
            dist_id[v],
            (i0 + 0.5) * res,
            (i1 - 0.5) * res,
            (j0 + 0.5) * res,
            (j1 - 0.5) * res,
            (k0 + 0.5) * res,
            (k1 - 0.5) * res,
        )
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
            packed,
            v0,
            nv,
            sel,
            nsel,
            cconst,
            precise,
            (i0 + 0.5) * res,
            (j0 + 0.5) * res,
            (k0 + 0.5) * res,
            res,
            F.shape[1],
            F,
            F32,
            buf,
            buf32,
        )
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


@njit(**NJIT_OPTIONS)
def _tile_range(
    g0,
    g1,
    src,
    dst,
    flags,
    value_offsets,
    shapes,
    resolutions,
    in_scale,
    view_offsets,
    packed,
    tile,
    tile_offsets,
    tile_live,
    tile_sum,
    tile_max,
    sel,
    nsel,
    cconst,
    F,
    F32,
    buf,
    buf32,
):  # pragma: no cover - compiled
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
            value_offsets[s],
            nj,
            nk,
            i0,
            min(i0 + tile[0], ni),
            j0,
            min(j0 + tile[1], nj),
            k0,
            min(k0 + tile[2], nk),
            tile[1],
            tile[2],
            view_offsets[s],
            view_offsets[s + 1] - view_offsets[s],
        )
        ts, tm = _tile_update(
            src,
            dst,
            (inplace, prior_one, log_space, tile_live[g], precise),
            geo,
            resolutions[s],
            in_scale[s],
            packed,
            sel,
            nsel,
            cconst,
            F,
            F32,
            buf,
            buf32,
        )
        tile_sum[g] = ts
        tile_max[g] = tm


@njit(parallel=True, **NJIT_OPTIONS)
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
    packed,
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
    packed : :class:`monovisual3d.methods.paper.engine.params.PackedViews`, the views (a named tuple of arrays)
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
    box_off = packed.box_offsets
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
    flags = (inplace, prior_one, log_space, precise)
    n_tasks = (n_tiles + TILES_PER_TASK - 1) // TILES_PER_TASK
    for c in prange(n_tasks):
        tid = numba.get_thread_id()
        _tile_range(
            c * TILES_PER_TASK,
            min((c + 1) * TILES_PER_TASK, n_tiles),
            src,
            dst,
            flags,
            value_offsets,
            shapes,
            resolutions,
            in_scale,
            view_offsets,
            packed,
            tile,
            tile_offsets,
            tile_live,
            tile_sum,
            tile_max,
            sel[tid],
            nsel[tid],
            cconst[tid],
            F,
            F32,
            buf[tid],
            buf32[tid],
        )


@njit(parallel=True, **NJIT_OPTIONS)
def scale_inplace(values, factor):  # pragma: no cover - compiled
    """``values *= factor`` in parallel (the normalisation pass)."""
    for c in prange(values.shape[0]):
        values[c] = values[c] * factor


@njit(parallel=True, **NJIT_OPTIONS)
def exp_shift(values, offset, out):  # pragma: no cover - compiled
    """``out = exp(values - offset)`` (log-space state to a linear posterior)."""
    for c in prange(values.shape[0]):
        out[c] = np.exp(values[c] - offset)
