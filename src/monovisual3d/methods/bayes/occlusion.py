"""Which box edges a nearer object hides: the occlusion flags of the shape stage.

An object's box edge is cut where a nearer object covers it. :func:`occluded_edges` asks whether a nearer
silhouette covers the extreme point that sets the edge (a round fruit's outline), :func:`covered_sides` whether a
nearer box covers the whole side (a tall object's edge stays while any part of its side shows);
:func:`occlusion_flags` applies either to every object of a result, from the objects' predicted boxes, and says how far
each edge a shape fit leaves out may be hidden (the far side of the nearer box).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .box_sides import boxes_near, covered_pairs, ends_pairs, occluded_pairs
from .problem import Problem
from .refine import Observation
from .scoring import associations_list, observations, predicted_boxes
from .sensor import box_edge_sigma_px
from .state import Found

#: The occlusion refit censors an edge when a nearer object's silhouette covers its extreme point by at least this
#: many standard deviations of the two objects' projected positions (:func:`occluded_edges`): a chosen margin
#: against the noise of the estimates, not a fitted one.
OCCLUSION_MARGIN_SIGMAS = 2.0


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
    out = covered_pairs(predicted, nearer, margin)
    if straight.any():  # each straight occluder covers and ends the edge itself
        sigma = box_edge_sigma_px(problem.model, observed[straight])
        out[straight] &= ends_pairs(observed[straight], nearer[straight], margin[straight], sigma)
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
        boxes_near(boxes, OCCLUSION_MARGIN_SIGMAS * std) & (depth[None, :] < depth[:, None]) & counted[None, :]
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
    np.logical_or.at(shifted, i, occluded_pairs(boxes[i], boxes[j], margin))
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
