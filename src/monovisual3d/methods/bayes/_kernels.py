"""Fused numba kernels of the ``bayes`` search.

- :func:`score_hypotheses` computes exactly what
  :func:`monovisual3d.methods.bayes.likelihood.view_scores` summed over views computes
  (the numpy reference, tested against this), in one parallel pass with no
  temporaries: per hypothesis and view, the predicted box, then the best box
  score or the miss term.
- :func:`cone_counts_fused` is :func:`monovisual3d.grid.cone_counts`
  (the numpy reference) in one parallel pass: in how many views each point
  projects inside a widened box.
- :func:`box_dominated_fused` is :func:`monovisual3d.methods.bayes.search.box_dominated`
  (the numpy reference) in two passes over the scored hypotheses, without temporaries.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from ...kernels.jit import kernel
from ...kernels.threads import kernel_threads
from ._predict import _distort_xy, _in_front, _spheroid_box_px, camera_arrays
from .boxindex import SCAN_BELOW_BOXES, TileIndex, build_index
from .sensor import SensorModel

#: Single-thread cost of one hypothesis against one box of a scanned view in ``_score_kernel``, and of one
#: hypothesis in a view looked up in the tile index, nanoseconds (the thread count's work estimate, see
#: :mod:`monovisual3d.kernels.threads`; measured on plant rows of 48 boxes per view: 210-290 ns single-threaded
#: at load 4, against 450-540 ns for the former edge index whose idle figure was 320).
NS_PER_HYPOTHESIS_BOX, NS_PER_HYPOTHESIS_VIEW = 20.0, 160.0
#: Single-thread cost of one point in one view in ``_cone_kernel``, nanoseconds.
NS_PER_POINT_VIEW = 20.0


def _edge_ll(d: float, sigma: float, in_floor: float, out_floor: float) -> float:  # pragma: no cover - jitted
    e = d / sigma
    ll = -0.5 * e * e
    if e > 0:
        return ll if ll > -in_floor else -in_floor
    return ll if ll > -out_floor else -out_floor


#: Stands for infinity inside the fast-math kernels (which may assume that no value is infinite).
HUGE = 1e300


def _beats(s: float, j: int, best: float, found: int) -> bool:  # pragma: no cover - jitted
    """Whether box ``j`` scoring ``s`` replaces the best so far: the scan's rule (highest score, then lowest index)."""
    return s > best or (s == best and found >= 0 and j < found)


def _box_score(
    b, j, px1, py1, px2, py2, sx, sy, wx, wy, W, H, border, in_floor, out_floor, bonus, best, found
):  # pragma: no cover
    """Score of box ``b`` (4,) index ``j``, or -inf outside the gate (the prediction widened by ``wx``, ``wy`` pixels)
    or as soon as a partial sum shows it cannot beat ``best``."""
    bx1, by1, bx2, by2 = b[0], b[1], b[2], b[3]
    d1 = bx1 - px1
    if bx1 <= border and d1 > 0:
        d1 = 0.0
    d3 = px2 - bx2
    if bx2 >= W - border and d3 > 0:
        d3 = 0.0
    d2 = by1 - py1
    if by1 <= border and d2 > 0:
        d2 = 0.0
    d4 = py2 - by2
    if by2 >= H - border and d4 > 0:
        d4 = 0.0
    gx = (px2 - px1) + wx
    gy = (py2 - py1) + wy
    if d1 > gx or d3 > gx or d2 > gy or d4 > gy:  # the box lies beside the widened prediction (sensor.outside_gate)
        return -HUGE
    s = bonus + _edge_ll(d1, sx, in_floor, out_floor)
    if not _beats(s, j, best, found):  # the other edges can only lower the score
        return -HUGE
    s += _edge_ll(d3, sx, in_floor, out_floor)
    if not _beats(s, j, best, found):
        return -HUGE
    s += _edge_ll(d2, sy, in_floor, out_floor)
    if not _beats(s, j, best, found):
        return -HUGE
    return s + _edge_ll(d4, sy, in_floor, out_floor)


def _query(index, v, qx1, qy1, qx2, qy2, out):  # pragma: no cover - jitted
    """Boxes of view ``v`` listed in the tiles of the rectangle ``q`` (pixels), each once, written to ``out``; their number.

    The twin of :func:`.boxindex.candidate_boxes`: a box is reported in the tile where its top-left tile and the
    query's meet.
    """
    count, tile, n_cols, n_rows, start, entries, corner = index
    t = tile[v]
    nc, nr = n_cols[v], n_rows[v]
    c1 = min(max(int(math.floor(qx1 / t)), 0), nc - 1) if qx1 > -HUGE else 0
    c2 = min(max(int(math.floor(qx2 / t)), 0), nc - 1) if qx2 < HUGE else nc - 1
    r1 = min(max(int(math.floor(qy1 / t)), 0), nr - 1) if qy1 > -HUGE else 0
    r2 = min(max(int(math.floor(qy2 / t)), 0), nr - 1) if qy2 < HUGE else nr - 1
    m = 0
    for r in range(r1, max(r1, r2) + 1):
        for c in range(c1, max(c1, c2) + 1):
            k = r * nc + c
            for pos in range(start[v, k], start[v, k + 1]):
                j = entries[v, pos]
                if c == max(corner[v, j, 0], c1) and r == max(corner[v, j, 1], r1):
                    out[m] = j
                    m += 1
    return m


def _cell_shift_px(fmax, half_diagonal, Z):  # pragma: no cover - jitted
    """:func:`.sensor.cell_shift_px` (the on-axis factor): ``f * h / (Z - h)`` (``f``: the largest focal length times
    the distortion's stretch), HUGE when the cell reaches the camera plane, 0 for a point."""
    if half_diagonal == 0.0:
        return 0.0
    near = Z - half_diagonal
    return fmax * half_diagonal / near if near > 1e-6 else HUGE


def _best_box(v, boxes, available, cand, m, px1, py1, px2, py2, sx, sy, wx, wy, cam, params):  # pragma: no cover - jitted
    """The best available box of view ``v`` for one predicted box (edge noise ``sx``, ``sy``, gate widening ``wx``, ``wy``,
    pixels): (score, index), (miss, -1) when none beats a miss.

    Scores the ``m`` boxes of ``cand`` (the tile look-up of :func:`_query`), or every box of the view when
    ``m < 0``, in any order; the tie rule of :func:`_beats` makes the result the scan's.
    """
    W, H = cam[4], cam[5]
    in_floor, out_floor, bonus, miss, border = params[2], params[3], params[4], params[5], params[6]
    best = miss
    found = -1
    n = m if m >= 0 else boxes.shape[1]
    for i in range(n):
        j = cand[i] if m >= 0 else i
        if available[v, j]:
            s = _box_score(
                boxes[v, j], j, px1, py1, px2, py2, sx, sy, wx, wy, W, H, border, in_floor, out_floor, bonus, best, found
            )
            if _beats(s, j, best, found):
                best = s
                found = j
    return best, found


def _score_one(
    n,
    centres,
    radii,
    semi_up,
    axis_opt,
    mask,
    T_ob,
    boxes,
    index,
    available,
    cam,
    code,
    coeffs,
    params,
    cell_half_diagonal,
    distortion_gain,
    position_sigma,
    extra_const_px,
    total,
    n_assoc,
    assoc,
):  # pragma: no cover - jitted
    """The scores of hypothesis row ``n`` of :func:`_score_kernel`: one body, compiled once outside the parallel loop
    (numba's parallel passes over this body inlined took three quarters of the search's compile time, issue 56)."""
    K = radii.shape[0]
    V = T_ob.shape[0]
    fx, fy, cx, cy, W, H = cam[0], cam[1], cam[2], cam[3], cam[4], cam[5]
    alpha, sigma0, gate = params[0], params[1], params[7]
    fmax = fx if fx > fy else fy
    count = index[0]
    pred = np.empty((K, 8))  # per shape bin in the current view: predicted box, sx, sy, gate widening x, y
    seen = np.zeros(K, dtype=np.bool_)
    cand = np.empty(max(boxes.shape[1], 1), dtype=np.int64)
    for kk in range(K):
        total[n, kk] = 0.0
        n_assoc[n, kk] = 0
        for v in range(V):
            assoc[v, n, kk] = -1
        if not mask[n, kk]:
            total[n, kk] = -math.inf
    for v in range(V):
        X = T_ob[v, 0, 0] * centres[n, 0] + T_ob[v, 0, 1] * centres[n, 1] + T_ob[v, 0, 2] * centres[n, 2] + T_ob[v, 0, 3]
        Y = T_ob[v, 1, 0] * centres[n, 0] + T_ob[v, 1, 1] * centres[n, 1] + T_ob[v, 1, 2] * centres[n, 2] + T_ob[v, 1, 3]
        Z = T_ob[v, 2, 0] * centres[n, 0] + T_ob[v, 2, 1] * centres[n, 1] + T_ob[v, 2, 2] * centres[n, 2] + T_ob[v, 2, 3]
        zc = Z if Z > 1e-6 else 1e-6
        eb = fmax * cell_half_diagonal / zc
        ep = fmax * position_sigma / zc
        gate2 = ep * ep + extra_const_px * extra_const_px  # noise of the gate: without the cell
        extra2 = eb * eb + gate2  # noise of the score: the cell blurs it too
        shift = _cell_shift_px(fmax * distortion_gain, cell_half_diagonal, Z)
        qx1, qy1, qx2, qy2 = HUGE, HUGE, -HUGE, -HUGE  # the union of the bins' gates: one look-up for all bins
        for kk in range(K):
            seen[kk] = False
            if not mask[n, kk] or not _in_front(Z, radii[kk], semi_up[kk], axis_opt[v, kk, 2]):
                continue
            ux, uy, uz = axis_opt[v, kk, 0], axis_opt[v, kk, 1], axis_opt[v, kk, 2]
            px1, py1, px2, py2 = _spheroid_box_px(X, Y, Z, radii[kk], semi_up[kk], ux, uy, uz, fx, fy, cx, cy, code, coeffs)
            if not (px2 > 0 and px1 < W and py2 > 0 and py1 < H):
                continue
            sx0 = alpha * (px2 - px1) + sigma0
            sy0 = alpha * (py2 - py1) + sigma0
            sx, sy, gsx, gsy = sx0, sy0, sx0, sy0
            if extra2 > 0:
                sx = math.sqrt(sx0 * sx0 + extra2)
                sy = math.sqrt(sy0 * sy0 + extra2)
            if gate2 > 0:
                gsx = math.sqrt(sx0 * sx0 + gate2)
                gsy = math.sqrt(sy0 * sy0 + gate2)
            ex = max(abs(px1 - cx), abs(px2 - cx)) / fx
            ey = max(abs(py1 - cy), abs(py2 - cy)) / fy
            wx = gate * gsx + shift * math.sqrt(1.0 + ex * ex)
            wy = gate * gsy + shift * math.sqrt(1.0 + ey * ey)
            seen[kk] = True
            pred[kk, 0], pred[kk, 1], pred[kk, 2], pred[kk, 3] = px1, py1, px2, py2
            pred[kk, 4], pred[kk, 5], pred[kk, 6], pred[kk, 7] = sx, sy, wx, wy
            qx1 = min(qx1, px1 - wx)
            qy1 = min(qy1, py1 - wy)
            qx2 = max(qx2, px2 + wx)
            qy2 = max(qy2, py2 + wy)
        if qx2 < qx1:  # no bin in the image
            continue
        m = -1
        if count[v] > SCAN_BELOW_BOXES:
            m = _query(index, v, qx1, qy1, qx2, qy2, cand)
        for kk in range(K):
            if not seen[kk]:
                continue
            best, found = _best_box(
                v,
                boxes,
                available,
                cand,
                m,
                pred[kk, 0],
                pred[kk, 1],
                pred[kk, 2],
                pred[kk, 3],
                pred[kk, 4],
                pred[kk, 5],
                pred[kk, 6],
                pred[kk, 7],
                cam,
                params,
            )
            total[n, kk] += best
            if found >= 0:
                n_assoc[n, kk] += 1
                assoc[v, n, kk] = found


def _score_kernel(
    centres,
    radii,
    semi_up,
    axis_opt,
    mask,
    T_ob,
    boxes,
    index,
    available,
    cam,
    code,
    coeffs,
    params,
    cell_half_diagonal,
    distortion_gain,
    position_sigma,
    extra_const_px,
    total,
    n_assoc,
    assoc,
):  # pragma: no cover - jitted
    for n in numba.prange(centres.shape[0]):
        _score_one(
            np.int64(n),  # the parallel loop's index is unsigned: one signed type, one compiled body
            centres,
            radii,
            semi_up,
            axis_opt,
            mask,
            T_ob,
            boxes,
            index,
            available,
            cam,
            code,
            coeffs,
            params,
            cell_half_diagonal,
            distortion_gain,
            position_sigma,
            extra_const_px,
            total,
            n_assoc,
            assoc,
        )


def _cone_kernel(centres, T_ob, boxes, nboxes, cam, code, coeffs, half_diagonal, widen, counts):  # pragma: no cover - jitted
    N = centres.shape[0]
    V = T_ob.shape[0]
    fx, fy, cx, cy = cam[0], cam[1], cam[2], cam[3]
    fmax = fx if fx > fy else fy
    for n in numba.prange(N):
        c = 0
        for v in range(V):
            if nboxes[v] == 0:
                continue
            X = T_ob[v, 0, 0] * centres[n, 0] + T_ob[v, 0, 1] * centres[n, 1] + T_ob[v, 0, 2] * centres[n, 2] + T_ob[v, 0, 3]
            Y = T_ob[v, 1, 0] * centres[n, 0] + T_ob[v, 1, 1] * centres[n, 1] + T_ob[v, 1, 2] * centres[n, 2] + T_ob[v, 1, 3]
            Z = T_ob[v, 2, 0] * centres[n, 0] + T_ob[v, 2, 1] * centres[n, 1] + T_ob[v, 2, 2] * centres[n, 2] + T_ob[v, 2, 3]
            if not (Z > 1e-6):
                # a point whose region reaches behind the camera gets the benefit of the doubt
                if Z > -half_diagonal:
                    c += 1
                continue
            xd, yd = _distort_xy(X / Z, Y / Z, code, coeffs)
            u = fx * xd + cx
            w = fy * yd + cy
            margin = fmax * half_diagonal / Z + 2.0
            for j in range(nboxes[v]):
                x1, y1, x2, y2 = boxes[v, j, 0], boxes[v, j, 1], boxes[v, j, 2], boxes[v, j, 3]
                wx = widen * (x2 - x1) + margin
                wy = widen * (y2 - y1) + margin
                if u >= x1 - wx and u <= x2 + wx and w >= y1 - wy and w <= y2 + wy:
                    c += 1
                    break
        counts[n] = c


def cone_counts_fused(
    camera: Camera,
    T_optical_base: list[NDArray[np.float64]],
    boxes: list[NDArray[np.float64]],
    centres_base: NDArray[np.float64],
    half_diagonal: float,
    widen: float = 0.5,
) -> NDArray[np.int32]:
    """:func:`monovisual3d.grid.cone_counts` (the numpy reference) in one parallel pass over the points."""
    T, B, nb, _ = pack_views(camera, T_optical_base, boxes, [np.ones(len(b), np.bool_) for b in boxes])
    cam, code, coeffs = camera_arrays(camera)
    counts = np.empty(len(centres_base), dtype=np.int32)
    with kernel_threads(int(NS_PER_POINT_VIEW * len(centres_base) * len(boxes))):
        _cone_kernel(
            np.ascontiguousarray(centres_base, dtype=np.float64),
            T,
            B,
            nb,
            cam,
            code,
            coeffs,
            float(half_diagonal),
            float(widen),
            counts,
        )
    return counts


def _dominated_kernel(total, assoc, n_boxes, margin, best, out):  # pragma: no cover - jitted
    N, K = total.shape
    V = assoc.shape[0]
    for v in range(V):
        for j in range(n_boxes[v]):
            best[v, j] = -math.inf
        for n in range(N):
            for k in range(K):
                j = assoc[v, n, k]
                if j >= 0 and math.isfinite(total[n, k]) and total[n, k] > best[v, j]:
                    best[v, j] = total[n, k]
    for n in range(N):
        for k in range(K):
            s = total[n, k]
            dominated, used = True, False
            if math.isfinite(s):  # as the reference: a score of +-inf or NaN is not a scored hypothesis
                for v in range(V):  # most hypotheses are not dominated and stop at their first box
                    j = assoc[v, n, k]
                    if j >= 0:
                        used = True
                        if not s < best[v, j] - margin:
                            dominated = False
                            break
            out[n, k] = dominated and used


def box_dominated_fused(
    total: NDArray[np.float64], assoc: NDArray[np.int16], n_boxes: list[int], margin: float
) -> NDArray[np.bool_]:
    """:func:`monovisual3d.methods.bayes.search.box_dominated` (the numpy reference), compiled: the best score of any
    hypothesis using each box in one pass, then each hypothesis against its boxes' best."""
    out = np.zeros(total.shape, dtype=np.bool_)
    if not math.isfinite(margin):
        return out
    best = np.empty((len(n_boxes), max(max(n_boxes, default=0), 1)))
    total, assoc = np.ascontiguousarray(total, dtype=np.float64), np.ascontiguousarray(assoc, dtype=np.int16)
    _dominated_kernel(total, assoc, np.asarray(n_boxes, dtype=np.int64), float(margin), best, out)
    return out


_edge_ll = numba.njit(cache=True, inline="always")(_edge_ll)
_query = numba.njit(cache=True, inline="always")(_query)
_cell_shift_px = numba.njit(cache=True, inline="always")(_cell_shift_px)
_beats = numba.njit(cache=True, inline="always")(_beats)
_box_score = numba.njit(cache=True, inline="always", fastmath=True)(_box_score)
_best_box = numba.njit(cache=True, inline="always", fastmath=True)(_best_box)
_score_one = numba.njit(cache=True, fastmath=True)(_score_one)
_score_kernel = kernel("bayes", parallel=True, fastmath=True)(_score_kernel)
_cone_kernel = kernel("bayes", parallel=True)(_cone_kernel)
_dominated_kernel = kernel("bayes")(_dominated_kernel)


def pack_views(
    camera: Camera,
    T_optical_base: list[NDArray[np.float64]],
    boxes: list[NDArray[np.float64]],
    available: list[NDArray[np.bool_]],
):
    """Pack per-view data into the kernel's arrays."""
    V = len(boxes)
    bmax = max((len(b) for b in boxes), default=0)
    T = np.zeros((V, 3, 4))
    B = np.zeros((V, max(bmax, 1), 4))
    nb = np.zeros(V, dtype=np.int64)
    A = np.zeros((V, max(bmax, 1)), dtype=np.bool_)
    for v in range(V):
        T[v] = T_optical_base[v][:3, :4]
        nb[v] = len(boxes[v])
        if len(boxes[v]):
            B[v, : len(boxes[v])] = boxes[v]
            A[v, : len(boxes[v])] = available[v]
    return T, B, nb, A


def score_work_ns(n_boxes: NDArray[np.int64]) -> float:
    """Estimated single-thread nanoseconds of ``_score_kernel`` per hypothesis for views of ``n_boxes`` boxes."""
    scanned = n_boxes <= SCAN_BELOW_BOXES
    return float(NS_PER_HYPOTHESIS_BOX * n_boxes[scanned].sum() + NS_PER_HYPOTHESIS_VIEW * np.count_nonzero(~scanned))


def model_params(model: SensorModel) -> NDArray[np.float64]:
    return np.array(
        [
            model.alpha,
            model.sigma0_px,
            model.inward_floor,
            model.outward_floor,
            model.match_bonus,
            model.miss_term,
            model.border_px,
            model.gate_sigmas,
        ]
    )


def score_hypotheses(
    camera: Camera,
    T_optical_base: list[NDArray[np.float64]],
    boxes: list[NDArray[np.float64]],
    available: list[NDArray[np.bool_]],
    centres_base: NDArray[np.float64],
    radii: NDArray[np.float64],
    model: SensorModel,
    cell_half_diagonal: float,
    extra_const_px: float = 0.0,
    mask: NDArray[np.bool_] | None = None,
    semi_up: NDArray[np.float64] | None = None,
    up_base: NDArray[np.float64] | None = None,
    index: TileIndex | None = None,
    position_sigma: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.int16]]:
    """Score every (centre, radius) hypothesis against all views.

    With ``semi_up`` (K,) metres and the unit axis ``up_base`` (3,), or one per bin (K, 3), base frame, bin ``k`` is
    a spheroid with semi-axes ``radii[k]`` across and ``semi_up[k]`` along its axis (a sphere where they are equal):
    upright along ``up``, or lying with a horizontal axis.

    The edge noise of a hypothesis at depth ``Z`` in a view gets ``f * cell_half_diagonal / Z``,
    ``f * position_sigma / Z`` and ``extra_const_px`` (pixels) added in quadrature (``f = max(fx, fy)``): the
    projected size of the region a grid cell stands for, the camera's position uncertainty, and depth-independent
    terms such as its rotation uncertainty. The association gate (:func:`.sensor.gate_widening_px`) widens the
    prediction by ``gate_sigmas`` sigmas of the noise without the cell, plus the most the cell's points can move the
    prediction's edges (:func:`.sensor.cell_shift_px`): a bounded shift, not a noise.

    ``mask`` (N, K) bool, optional, selects the hypotheses to score; the others
    get ``total = -inf``, ``n_assoc = 0`` and no association (the search uses
    it to skip the radii a parent cell already ruled out). ``index`` is :func:`.boxindex.build_index` of
    ``boxes`` for ``model`` (built here when not given): each hypothesis scores only the boxes it can
    match, with the same result as scoring all of them.

    Returns
    -------
    total : ndarray, shape (N, K), nats
    n_assoc : ndarray, shape (N, K), int32, views with an associated box
    assoc : ndarray, shape (V, N, K), int16, associated box per view, -1 for none
    """
    T, B, nb, A = pack_views(camera, T_optical_base, boxes, available)
    cam, code, coeffs = camera_arrays(camera)
    if index is None:
        index = build_index(boxes, camera.width, camera.height)
    total = np.empty((len(centres_base), len(radii)))
    n_assoc = np.empty((len(centres_base), len(radii)), dtype=np.int32)
    assoc = np.empty((len(boxes), len(centres_base), len(radii)), dtype=np.int16)
    if mask is None:
        mask = np.ones(total.shape, dtype=np.bool_)
    elif mask.shape != total.shape:
        raise ValueError(f"mask: shape {mask.shape}, expected {total.shape} (centres, radii)")
    semi_up = radii if semi_up is None else semi_up
    up = np.zeros(3) if up_base is None else np.asarray(up_base, dtype=float)
    axes = np.broadcast_to(up, (len(radii), 3))
    axis_opt = np.ascontiguousarray(np.einsum("vij,kj->vki", T[:, :, :3], axes))  # (V, K, 3): each bin's axis per view
    with kernel_threads(int(total.size * score_work_ns(nb))):
        _score_kernel(
            np.ascontiguousarray(centres_base, dtype=np.float64),
            np.ascontiguousarray(radii, dtype=np.float64),
            np.ascontiguousarray(semi_up, dtype=np.float64),
            axis_opt,
            np.ascontiguousarray(mask, dtype=np.bool_),
            T,
            B,
            index.as_tuple(),
            A,
            cam,
            code,
            coeffs,
            model_params(model),
            float(cell_half_diagonal),
            camera.distortion_gain() if cell_half_diagonal > 0 else 1.0,
            float(position_sigma),
            float(extra_const_px),
            total,
            n_assoc,
            assoc,
        )
    return total, n_assoc, assoc
