"""Which box edges a nearer object hides: the occlusion flags of the shape stage.

An object's box edge is cut where a nearer object covers it. :func:`occluded_edges` asks whether a nearer
silhouette covers the extreme point that sets the edge (a round fruit's outline), :func:`covered_sides` whether a
nearer box covers the whole side (a tall object's edge stays while any part of its side shows);
:func:`occlusion_flags` applies either to every object of a result, from the objects' predicted boxes, and says how far
each edge a shape fit leaves out may be hidden (the far side of the nearer box).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .problem import Problem
from .refine import Observation
from .scoring import associations_list, observations, predicted_boxes
from .sensor import box_edge_sigma_px
from .state import Found

#: The occlusion refit censors an edge when a nearer object's silhouette covers its extreme point by at least this
#: many standard deviations of the two objects' projected positions (:func:`occluded_edges`): a chosen margin
#: against the noise of the estimates, not a fitted one.
OCCLUSION_MARGIN_SIGMAS = 2.0
#: An observed edge ends at an occluder when it lies within this many edge-noise sigmas (plus the occluder's
#: uncertainty) of the occluder's facing edge (:func:`ends_at_occluder`).
EDGE_AT_OCCLUDER_SIGMAS = 3.0


def _predicted(
    problem: Problem, objects: list[Found], v: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Predicted boxes (N, 4), pixels, centre depths (N,), metres, and the std (N, 2), pixels, of each object's
    projected centre along x and y in view ``v`` (its position covariance through the pinhole projection's
    Jacobian; without a covariance, its box's edge noise)."""
    cam, R = problem.camera, problem.views[v].T_optical_base[:3, :3]
    if not objects:
        return np.full((0, 4), np.nan), np.zeros(0), np.zeros((0, 2))
    boxes, _, p_opt = predicted_boxes(problem, v, objects)
    depth = p_opt[:, 2].copy()
    std = box_edge_sigma_px(problem.model, boxes)[:, :2]
    known = np.array([o.covariance is not None for o in objects]) & (depth > 0)
    if known.any():
        x, y, z = p_opt[known].T
        zero = np.zeros_like(z)
        J = (
            np.stack(
                [np.stack([cam.fx + zero, zero, -cam.fx * x / z], -1), np.stack([zero, cam.fy + zero, -cam.fy * y / z], -1)], 1
            )
            / z[:, None, None]
        )
        cov = np.array([objects[i].covariance for i in np.flatnonzero(known)], dtype=float)
        var = np.diagonal(J @ R @ cov @ R.T @ np.swapaxes(J, 1, 2), axis1=1, axis2=2)  # of the projected centre
        std[known] = np.sqrt(np.maximum(var, 0.0))
    return boxes, depth, std


def occluded_edges(pred: NDArray[np.float64], nearer: NDArray[np.float64], margin_px: ArrayLike = 0.0) -> NDArray[np.bool_]:
    """Edges ``x1, y1, x2, y2`` of an object's box that a nearer object hides, shape (4,).

    The edge of a convex silhouette's box is set by its extreme point on that side; the box is cut there
    when a nearer silhouette covers that point. Silhouettes are taken as the ellipses inscribed in the
    predicted boxes (exact for a sphere seen on the optical axis, close to it in a usual field of view).

    Parameters
    ----------
    pred : ndarray, shape (4,), the object's predicted box, pixels
    nearer : ndarray, shape (N, 4), predicted boxes of the objects nearer the camera, pixels
    margin_px : float or ndarray, shape (N, 2), pixels: a point counts as covered only this far inside a nearer
        silhouette (its half-width and half-height shrunk by it), so that the noise of the estimates does not
        censor a full edge

    Examples
    --------
    >>> occluded_edges(np.array([10.0, 0, 50, 40]), np.array([[40.0, 5, 80, 30]])).tolist()
    [False, False, True, False]
    """
    return _occluded_pairs(*_against(pred, nearer, margin_px)).any(axis=0)


def _against(
    box: NDArray[np.float64], nearer: NDArray[np.float64], margin_px: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``box`` (4,) paired with each of ``nearer`` (N, 4), with the margins (N, 2): the pairwise tests' arguments."""
    nearer = np.asarray(nearer, dtype=float).reshape(-1, 4)
    m = np.broadcast_to(np.asarray(margin_px, dtype=float), (len(nearer), 2))
    return np.broadcast_to(np.asarray(box, dtype=float), nearer.shape), nearer, m


def _finite_pairs(*boxes: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Pairs (P,) whose boxes (each (P, 4)) are all finite: a box with a NaN flags nothing."""
    return np.logical_and.reduce([np.all(np.isfinite(b), axis=1) for b in boxes])


def _occluded_pairs(pred: NDArray[np.float64], nearer: NDArray[np.float64], margin: NDArray[np.float64]) -> NDArray[np.bool_]:
    """:func:`occluded_edges` pair by pair: the edges (P, 4) of each box ``pred`` (P, 4) whose extreme point the
    silhouette of its ``nearer`` box (P, 4), shrunk by ``margin`` (P, 2), covers."""
    x1, y1, x2, y2 = pred.T
    cx, cy = (x1 + x2) / 2, (y1 + y2) / 2
    points = np.stack([np.stack(p, axis=-1) for p in ((x1, cy), (cx, y1), (x2, cy), (cx, y2))], axis=1)  # (P, 4, 2)
    centre = (nearer[:, :2] + nearer[:, 2:]) / 2
    half = np.maximum((nearer[:, 2:] - nearer[:, :2]) / 2 - margin, 1e-9)
    with np.errstate(invalid="ignore"):  # NaN boxes: ruled out below
        inside = np.sum(((points - centre[:, None]) / half[:, None]) ** 2, axis=2) < 1.0
    return inside & _finite_pairs(pred, nearer)[:, None]


def covered_sides(pred: NDArray[np.float64], nearer: NDArray[np.float64], margin_px: ArrayLike = 0.0) -> NDArray[np.bool_]:
    """Edges ``x1, y1, x2, y2`` of an object's box along which a nearer box covers the whole side, shape (4,).

    The stricter test of :func:`occluded_edges` for the shape fits: a tall object's box edge is set by a whole side
    of its outline, not one extreme point, and stays where it is while any part of that side shows (a farther
    container's top above a nearer one). A nearer box (N, 4), shrunk by ``margin_px`` ((N, 2) or scalar, pixels),
    must reach across the edge, and span the box's whole extent along it to within the margin.

    Examples
    --------
    >>> covered_sides(np.array([100.0, 50, 160, 200]), np.array([[150.0, 40, 230, 210]])).tolist()
    [False, False, True, False]
    >>> covered_sides(np.array([100.0, 50, 160, 200]), np.array([[150.0, 60, 230, 210]])).tolist()  # its top shows
    [False, False, False, False]
    """
    return _covered_pairs(*_against(pred, nearer, margin_px)).any(axis=0)


def spans(box: NDArray[np.float64], nearer: NDArray[np.float64], tolerance_px: ArrayLike) -> NDArray[np.bool_]:
    """Whether a nearer box reaches over a box's whole height (column 0) and whole width (column 1), shape (P, 2):
    each of ``nearer`` (P, 4) against ``box`` (P, 4), where a side of ``box`` sticking out by up to ``tolerance_px``
    ((P, 4) per edge, or broadcastable, pixels) counts as covered (it would not be seen beyond the edge noise).

    Examples
    --------
    >>> spans(np.array([[100.0, 50, 160, 200]]), np.array([[150.0, 52, 230, 210]]), 3.0).tolist()
    [[True, False]]
    """
    box, n = np.asarray(box, dtype=float).reshape(-1, 4), np.asarray(nearer, dtype=float).reshape(-1, 4)
    tol = np.broadcast_to(np.asarray(tolerance_px, dtype=float), n.shape)
    spans_y = (n[:, 1] - tol[:, 1] <= box[:, 1]) & (n[:, 3] + tol[:, 3] >= box[:, 3])
    spans_x = (n[:, 0] - tol[:, 0] <= box[:, 0]) & (n[:, 2] + tol[:, 2] >= box[:, 2])
    return np.stack([spans_y, spans_x], axis=1)


def _covered_pairs(pred: NDArray[np.float64], n: NDArray[np.float64], m: NDArray[np.float64]) -> NDArray[np.bool_]:
    """:func:`covered_sides` pair by pair: the edges (P, 4) of each box ``pred`` (P, 4) whose whole side its nearer
    box ``n`` (P, 4), with the margin ``m`` (P, 2), covers."""
    x1, y1, x2, y2 = pred.T
    nx1, ny1, nx2, ny2 = n[:, 0] + m[:, 0], n[:, 1] + m[:, 1], n[:, 2] - m[:, 0], n[:, 3] - m[:, 1]
    # spanning is judged with the margin the other way: a side sticking out by less than the noise is not seen
    spans_y, spans_x = spans(pred, n, m[:, [0, 1, 0, 1]]).T
    out = np.stack(
        [
            spans_y & (nx1 < x1) & (nx2 > x1),
            spans_x & (ny1 < y1) & (ny2 > y1),
            spans_y & (nx1 < x2) & (nx2 > x2),
            spans_x & (ny1 < y2) & (ny2 > y2),
        ],
        axis=1,
    )
    return out & _finite_pairs(pred, n)[:, None]


def ends_at_occluder(
    observed: NDArray[np.float64], nearer: NDArray[np.float64], margin_px: ArrayLike, sigma_px: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Edges ``x1, y1, x2, y2`` of an observed box that lie where a nearer box (N, 4) begins, shape (4,): within
    ``margin_px`` ((N, 2) or scalar, the nearer box's uncertainty) plus :data:`EDGE_AT_OCCLUDER_SIGMAS` times the edge
    noise ``sigma_px`` (4,) of the facing edge (the left edge of a box to the nearer one's right edge, and so on).

    A detector of visible parts ends a box where the occluder begins; an edge well inside the occluder's box is the
    object's own edge drawn through the occluder (an amodal box, as an annotator draws it), and carries its position.

    Examples
    --------
    >>> sigma = np.full(4, 2.0)
    >>> ends_at_occluder(np.array([100.0, 50, 150, 200]), np.array([[150.0, 40, 230, 210]]), 0.0, sigma).tolist()
    [False, False, True, False]
    >>> ends_at_occluder(np.array([100.0, 50, 190, 200]), np.array([[150.0, 40, 230, 210]]), 0.0, sigma).tolist()
    [False, False, False, False]
    """
    obs, n, m = _against(observed, nearer, margin_px)
    return _ends_pairs(obs, n, m, np.broadcast_to(np.asarray(sigma_px, dtype=float), n.shape)).any(axis=0)


def _ends_pairs(
    observed: NDArray[np.float64], n: NDArray[np.float64], m: NDArray[np.float64], sigma: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """:func:`ends_at_occluder` pair by pair: boxes ``observed`` (P, 4) with edge noise ``sigma`` (P, 4), nearer boxes
    ``n`` (P, 4) with margins ``m`` (P, 2)."""
    tol = m[:, [0, 1, 0, 1]] + EDGE_AT_OCCLUDER_SIGMAS * sigma
    facing = n[:, [2, 3, 0, 1]]  # the nearer box's edge facing each edge of the observed box
    with np.errstate(invalid="ignore"):
        return (np.abs(facing - observed) <= tol) & _finite_pairs(observed, n)[:, None]


def _meeting(boxes: NDArray[np.float64], pad_px: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which of the boxes (N, 4), each widened by its ``pad_px`` (N, 2) along x and y, meet each other (closed
    intervals), shape (N, N); False on the diagonal and for a box with a NaN.

    The tests of :func:`occlusion_flags` flag an edge only where the nearer box, shrunk or grown by the pair's margin
    ``OCCLUSION_MARGIN_SIGMAS * hypot(std_i, std_j)`` (at most the sum of the two pads), reaches into the box or
    spans it: boxes that do not meet so widened have no flag to give each other.
    """
    lo, hi = boxes[:, :2] - pad_px, boxes[:, 2:] + pad_px
    out = np.all((lo[:, None, :] <= hi[None, :, :]) & (hi[:, None, :] >= lo[None, :, :]), axis=2)
    np.fill_diagonal(out, False)
    return out


def _whole_sides_pairs(
    problem: Problem,
    predicted: NDArray[np.float64],
    observed: NDArray[np.float64],
    nearer: NDArray[np.float64],
    margin: NDArray[np.float64],
    straight: NDArray[np.bool_],
) -> NDArray[np.bool_]:
    """The edges (P, 4) of each object's observed box ``observed`` (P, 4) a shape fit must leave out in one view: those
    whose whole side the pair's nearer predicted box ``nearer`` (P, 4), with the pair's margin ``margin`` (P, 2), covers
    around the object's ``predicted`` box (P, 4); behind an elongated occluder (``straight`` (P,)) only where the edge
    ends at that occluder's facing edge.

    An elongated occluder's side is straight along the side it covers: a box of the visible part ends at its box's
    edge, and an edge well inside it is an amodal box's own edge (a round one's cut edge lies anywhere inside its box).
    """
    out = _covered_pairs(predicted, nearer, margin)
    if straight.any():  # each straight occluder covers and ends the edge itself
        sigma = box_edge_sigma_px(problem.model, observed[straight])
        out[straight] &= _ends_pairs(observed[straight], nearer[straight], margin[straight], sigma)
    return out


#: Per view: the objects' predicted boxes (N, 4), centre depths (N,) and projected-centre stds (N, 2) (``_predicted``).
Predicted = list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]]


def predicted_views(problem: Problem, objects: list[Found]) -> Predicted:
    """What :func:`occlusion_flags` needs of every view, computed once for several calls on the same objects."""
    return [_predicted(problem, objects, v) for v in range(len(problem.views))]


def occlusion_flags(
    problem: Problem,
    objects: list[Found],
    trusted: list[bool] | None = None,
    whole_sides: bool = False,
    predicted: Predicted | None = None,
) -> list[tuple[list[Observation], frozenset[int]] | None]:
    """Per object, its observations with the edges a nearer object cuts flagged (``Observation.censored``) and the
    session indices of the views where any edge is cut; None for an object refined jointly with the poses or seen in
    fewer than ``min_views`` views.

    An edge counts as cut when a nearer object's predicted box covers the object's extreme point on that side by more
    than :data:`OCCLUSION_MARGIN_SIGMAS` times the uncertainty of the two objects' projected centres (from their
    position covariances), so that chance overlaps of noisy estimates cut nothing (:func:`occluded_edges`). With
    ``whole_sides`` only the edges whose whole side it covers are flagged (:func:`covered_sides`: the edges a shape fit
    must leave out), while the views are those where either test flags an edge (where the box's aspect is not the
    object's), and each observation's ``hidden_to`` says how far each such edge may be hidden (:func:`_hidden_to`).
    Only the nearer objects marked ``trusted`` count (default: all). ``predicted``: :func:`predicted_views` of
    ``objects``, when already computed.
    """
    cfg = problem.config
    preds = predicted_views(problem, objects) if predicted is None else predicted
    elongated = np.array([o.semi_up is not None for o in objects], dtype=bool)
    counted = np.ones(len(objects), dtype=bool) if trusted is None else np.asarray(trusted, dtype=bool)
    # [i, j]: object j is nearer than i, counts, and its predicted box comes within the pair's margin of i's (only
    # such an object can cut or cover an edge of i's box)
    meets = [
        _meeting(boxes, OCCLUSION_MARGIN_SIGMAS * std) & (depth[None, :] < depth[:, None]) & counted[None, :]
        for boxes, depth, std in preds
    ]
    assoc = [associations_list(problem, o) for o in objects]
    flags = [
        _view_flags(problem, pred, m, v, [a[v] for a in assoc], elongated, whole_sides)
        for v, (pred, m) in enumerate(zip(preds, meets))
    ]
    out: list[tuple[list[Observation], frozenset[int]] | None] = []
    for i, o in enumerate(objects):
        if o.pose_corrected or sum(a >= 0 for a in assoc[i]) < cfg.min_views:
            out.append(None)
            continue
        obs, cut = [], set()
        for ob, v in zip(observations(problem, assoc[i], o.position), [v for v, j in enumerate(assoc[i]) if j >= 0]):
            shifted, censored, hidden_to = flags[v]
            ob.censored, ob.hidden_to = censored[i].copy(), hidden_to[i].copy()
            if shifted[i].any() or ob.censored.any():
                cut.add(problem.views[v].index)
            obs.append(ob)
        out.append((obs, frozenset(cut)))
    return out


def _view_flags(
    problem: Problem,
    predicted: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    meets: NDArray[np.bool_],
    v: int,
    assoc: list[int],
    elongated: NDArray[np.bool_],
    whole_sides: bool,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.float64]]:
    """:func:`occlusion_flags` in view ``v`` for every object at once, from the objects' ``predicted`` boxes and stds,
    ``meets`` (N, N) and their boxes ``assoc`` (N,) in the view (-1: none): the edges (N, 4) a nearer object cuts at
    their extreme point, those censored (the same, or with ``whole_sides`` those whose whole side it covers), and with
    ``whole_sides`` how far each censored edge may be hidden (:func:`_hidden_to`; NaN elsewhere)."""
    boxes, _, std = predicted
    i, j = np.nonzero(meets)  # i farther, j nearer
    margin = OCCLUSION_MARGIN_SIGMAS * np.hypot(std[j], std[i])
    shifted = np.zeros((len(boxes), 4), dtype=bool)
    np.logical_or.at(shifted, i, _occluded_pairs(boxes[i], boxes[j], margin))
    hidden_to = np.full((len(boxes), 4), np.nan)
    if not whole_sides:
        return shifted, shifted, hidden_to
    observed = np.full((len(boxes), 4), np.nan)
    held = np.asarray(assoc, dtype=np.intp)
    observed[held >= 0] = problem.views[v].boxes[held[held >= 0]]
    censored = np.zeros((len(boxes), 4), dtype=bool)
    pairs = _whole_sides_pairs(problem, boxes[i], observed[i], boxes[j], margin, elongated[j])
    np.logical_or.at(censored, i, pairs)
    occluder = np.where(np.isfinite(observed[j]), observed[j], boxes[j])  # its box as seen, else as predicted
    return shifted, censored, _hidden_to(len(boxes), i, pairs, occluder, margin)


def _hidden_to(
    n: int, i: NDArray[np.intp], pairs: NDArray[np.bool_], occluder: NDArray[np.float64], margin: NDArray[np.float64]
) -> NDArray[np.float64]:
    """How far each edge (n, 4) of ``n`` objects' boxes may be hidden, pixels: the far side of the nearer box
    ``occluder`` (P, 4) of each pair (farther object ``i`` (P,)) that hides it (``pairs`` (P, 4)), widened by the
    pair's ``margin`` (P, 2); the farthest of several; NaN where no nearer box hides the edge.

    A box of an object's visible part ends at its occluder; the object cannot reach past the occluder's far side, or
    that part would show and the box would hold it."""
    widened = occluder + np.concatenate([-margin, margin], axis=1)
    out = np.full((n, 4), np.nan)
    low, high = np.full((n, 2), np.inf), np.full((n, 2), -np.inf)
    np.minimum.at(low, i, np.where(pairs[:, :2], widened[:, :2], np.inf))
    np.maximum.at(high, i, np.where(pairs[:, 2:], widened[:, 2:], -np.inf))
    out[:, :2] = np.where(np.isfinite(low), low, np.nan)
    out[:, 2:] = np.where(np.isfinite(high), high, np.nan)
    return out
