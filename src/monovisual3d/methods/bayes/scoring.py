"""Scoring and fitting single objects: the building blocks of every stage.

All functions are pure: they read a :class:`~.problem.Problem` and an explicit
``taken`` set (boxes already explained) and return new values.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...frames import transform_points
from ...geometry.spheroid import predict_spheroid_boxes
from ...grid import cell_half_diagonal
from ._kernels import score_hypotheses as score_hypotheses_fused
from .boxindex import TileIndex, build_index
from .likelihood import box_scores, pose_sigma_px, view_scores
from .problem import Problem
from .refine import Observation, Refined, refine_sphere, refine_spheroid
from .sensor import cell_shift_px, gate_widening_px
from .state import Found, Scores, Taken


def pose_px(problem: Problem, depth: NDArray[np.floating] | float) -> NDArray[np.float64] | float:
    """Edge noise (pixels) of the stated pose uncertainty at ``depth`` (metres); exactly 0.0 when poses are exact."""
    cfg = problem.config
    if not cfg.poses_uncertain:
        return 0.0
    return pose_sigma_px(problem.camera, depth, cfg.pose_position_sigma, cfg.pose_rotation_sigma)


#: Problems whose box index is kept (the last few: one estimate scores its problem thousands of times).
INDEX_CACHE_SIZE = 4
_INDEX_CACHE: list[tuple[Problem, TileIndex]] = []


def box_index(problem: Problem) -> TileIndex:
    """The problem's box index (:func:`.boxindex.build_index`), built once per problem."""
    for p, index in _INDEX_CACHE:
        if p is problem:
            return index
    cam = problem.camera
    index = build_index([vd.boxes for vd in problem.views], cam.width, cam.height)
    _INDEX_CACHE.insert(0, (problem, index))
    del _INDEX_CACHE[INDEX_CACHE_SIZE:]
    return index


def score_hypotheses(
    problem: Problem,
    taken: Taken,
    centres_base: NDArray[np.float64],
    radii: NDArray[np.float64],
    cell: float,
    mask: NDArray[np.bool_],
    semi_up: NDArray[np.float64] | None = None,
    axes: NDArray[np.float64] | None = None,
) -> Scores:
    """Score the (cell, radius) hypotheses selected by ``mask`` with the boxes not in ``taken``.

    Parameters
    ----------
    centres_base : ndarray, shape (N, 3), metres, base frame
    radii : ndarray, shape (K,), metres, semi-axis across ``up`` (the radius of a sphere)
    semi_up : ndarray, shape (K,), metres, optional: semi-axis along ``up`` (``BayesConfig.up``) of upright
        spheroid hypotheses (a sphere where it equals the radius; default: all spheres)
    axes : ndarray, shape (K, 3), unit, base frame, optional: each bin's symmetry axis (default ``up``; a lying
        bin's is horizontal), ``semi_up`` being the semi-axis along it
    cell : float, metres: the cell size; the cell's projected half-diagonal is added to the edge
        noise so a cell is scored as the region it stands for (0: a single point)
    mask : ndarray, shape (N, K), bool

    Returns
    -------
    total, n_assoc, assoc : see :data:`Scores`; an elongated bin's total is its log-likelihood ratio less
        ``elongation_cost`` (:func:`shape_cost`)
    """
    blur = cell_half_diagonal(cell)
    cfg, cam = problem.config, problem.camera
    available = problem.available(taken)
    if cfg.backend == "numba":
        # the pose's position uncertainty scales with 1/depth like the cell blur; its rotation part is constant
        scores = score_hypotheses_fused(
            cam,
            [vd.T_optical_base for vd in problem.views],
            [vd.boxes for vd in problem.views],
            available,
            centres_base,
            radii,
            problem.model,
            blur,
            max(cam.fx, cam.fy) * cfg.pose_rotation_sigma,
            mask,
            semi_up,
            cfg.up_vector if axes is None else axes,
            box_index(problem),
            cfg.pose_position_sigma,
        )
    else:
        scores = score_hypotheses_numpy(problem, available, centres_base, radii, blur, mask, semi_up, axes)
    if semi_up is not None and np.any(semi_up != radii):
        scores[0][:, semi_up != radii] -= cfg.tuning.elongation_cost
    return scores


def shape_cost(problem: Problem, semi_up: float | None) -> float:
    """Nats an upright-spheroid hypothesis pays against a sphere: ``elongation_cost`` (0 for a sphere).

    The Occam factor of the extra shape parameter: the prior spreads over the elongations searched, the
    boxes pin it to a fraction of that range, and without the cost chance alignments of false-positive
    boxes would find an elongated fit more often than a sphere.
    """
    return 0.0 if semi_up is None else float(problem.config.tuning.elongation_cost)


def score_hypotheses_numpy(
    problem: Problem,
    available: Sequence[NDArray[np.bool_]],
    centres_base: NDArray[np.float64],
    radii: NDArray[np.float64],
    blur: float,
    mask: NDArray[np.bool_],
    semi_up: NDArray[np.float64] | None = None,
    axes: NDArray[np.float64] | None = None,
) -> Scores:
    """The numpy reference of :func:`score_hypotheses` (``blur``: the cell's half-diagonal, metres)."""
    semi_up = radii if semi_up is None else semi_up
    up = problem.config.up_vector if axes is None else np.asarray(axes, dtype=float)
    cam, n, k = problem.camera, len(centres_base), len(radii)
    total = np.zeros((n, k))
    n_assoc = np.zeros((n, k), dtype=np.int32)
    assoc = np.empty((len(problem.views), n, k), dtype=np.int16)
    for v, vd in enumerate(problem.views):
        p_opt = transform_points(vd.T_optical_base, centres_base)
        pred, visible = predict_spheroid_boxes(cam, p_opt, radii, semi_up, up @ vd.T_optical_base[:3, :3].T)
        depth = p_opt[:, 2:3]
        extra = max(cam.fx, cam.fy) * blur / np.maximum(depth, 1e-6)
        noise = pose_px(problem, depth) if problem.config.poses_uncertain else 0.0
        extra = np.hypot(extra, noise)
        gate = gate_widening_px(problem.model, pred, noise, cell_shift_px(cam, pred, depth, blur))
        llr, a = view_scores(pred, visible, vd.boxes, available[v], problem.model, cam.width, cam.height, extra, gate)
        total += llr
        n_assoc += a >= 0
        assoc[v] = a
    total[~mask], n_assoc[~mask], assoc[:, ~mask] = -np.inf, 0, -1
    return total, n_assoc, assoc


def score_one(
    problem: Problem,
    taken: Taken,
    centre: NDArray[np.float64],
    radius: float,
    cell: float = 0.0,
    semi_up: float | None = None,
    axis: NDArray[np.float64] | None = None,
) -> tuple[float, list[int]]:
    """Score (nats) and best available box per view (-1: none) of one sphere (a spheroid with ``semi_up`` along
    ``axis``, default ``up``); ``cell`` > 0 blurs it as a grid cell."""
    b = None if semi_up is None else np.array([semi_up])
    axes = None if axis is None else np.asarray(axis, dtype=float)[None, :]
    total, _, assoc = score_hypotheses(
        problem, taken, centre[None, :], np.array([radius]), cell, np.ones((1, 1), dtype=bool), b, axes
    )
    return float(total[0, 0]), [int(a) for a in assoc[:, 0, 0]]


def observations(problem: Problem, assoc: Sequence[int], centre: NDArray[np.float64]) -> list[Observation]:
    """Observations of the associated boxes (-1: none), with the pose noise at ``centre``'s depth in each view."""
    use_masks = problem.config.use_masks
    out = []
    for v, (vd, j) in enumerate(zip(problem.views, assoc)):
        if j < 0:
            continue
        noise = float(pose_px(problem, problem.depth(v, centre)))
        out.append(Observation(vd.T_optical_base, vd.boxes[j], vd.contours[j] if use_masks else None, noise))
    return out


def _radius_ok(problem: Problem, radius: float, semi_up: float | None = None) -> bool:
    lo, hi = problem.config.fit_radius_range
    return lo <= radius <= hi and (semi_up is None or lo <= semi_up <= hi)


def spheroid_axis(problem: Problem, axis: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """A spheroid's symmetry axis, base frame: ``axis``, or ``up`` when None."""
    return problem.config.up_vector if axis is None else np.asarray(axis, dtype=float)


def shape_boxes(
    problem: Problem,
    v: int,
    centres_base: NDArray[np.float64],
    radii: NDArray[np.float64],
    semi_up: NDArray[np.float64],
    axes: Sequence[NDArray[np.float64] | None],
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """The boxes that M objects, each with its own shape, predict in view ``v``: the one place that says what an
    object's box is.

    Parameters
    ----------
    centres_base : ndarray, shape (M, 3), metres, base frame
    radii : ndarray, shape (M,), metres: the semi-axes across each object's axis
    semi_up : ndarray, shape (M,), metres: the semi-axes along it (``radii`` for a sphere)
    axes : M symmetry axes, base frame (None: ``up``)

    Returns
    -------
    boxes : ndarray, shape (M, 4), pixels, ``bbox_xyxy``
    visible : ndarray, shape (M,), bool: in front of the camera
    p_optical : ndarray, shape (M, 3), metres, the centres in the view's optical frame
    """
    T = problem.views[v].T_optical_base
    p_optical = np.asarray(centres_base, dtype=float).reshape(-1, 3) @ T[:3, :3].T + T[:3, 3]
    up_optical = np.array([spheroid_axis(problem, a) for a in axes], dtype=float).reshape(-1, 3) @ T[:3, :3].T
    radii, semi_up = np.asarray(radii, dtype=float), np.asarray(semi_up, dtype=float)
    boxes, visible = predict_spheroid_boxes(problem.camera, p_optical, radii[:, None], semi_up[:, None], up_optical[:, None])
    return boxes[:, 0], visible[:, 0], p_optical  # each centre with its own shape


def predicted_boxes(
    problem: Problem, v: int, objects: Sequence[Found]
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """:func:`shape_boxes` of found ``objects`` (M): each a sphere, or a spheroid along its axis."""
    return shape_boxes(
        problem,
        v,
        np.array([o.position for o in objects], dtype=float),
        np.array([float(o.radius) for o in objects]),  # type: ignore[arg-type]
        np.array([o.semi_up or float(o.radius) for o in objects]),  # type: ignore[arg-type]
        [o.axis for o in objects],
    )


def _refine(
    problem: Problem,
    obs: Sequence[Observation],
    centre: NDArray[np.float64],
    radius: float,
    semi_up: float | None,
    axis: NDArray[np.float64] | None = None,
) -> Refined:
    """A sphere through :func:`.refine.refine_sphere`, a spheroid (``semi_up`` along ``axis``, default ``up``)
    through ``refine_spheroid``."""
    cfg = problem.config
    if semi_up is None:
        return refine_sphere(problem.camera, obs, centre, radius, problem.model, use_masks=cfg.use_masks)
    return refine_spheroid(problem.camera, obs, centre, radius, semi_up, problem.model, spheroid_axis(problem, axis))


def _object(
    problem: Problem, refined: object, score: float, assoc: Sequence[int], n_views: int, axis: NDArray[np.float64] | None = None
) -> Found:
    """The accepted object; an undetermined covariance (singular Gauss-Newton matrix, e.g. all views from one
    pose) is reported as None, never as NaN."""
    cov = refined.covariance  # type: ignore[attr-defined]
    radius_std = float(refined.radius_std)  # type: ignore[attr-defined]
    semi_up = getattr(refined, "semi_up", None)
    lying = semi_up is not None and axis is not None and abs(float(np.dot(axis, problem.config.up_vector))) < 1 - 1e-9
    return Found(
        position=refined.centre,  # type: ignore[attr-defined]
        score=score,
        radius=float(refined.radius),  # type: ignore[attr-defined]
        covariance=cov if cov is not None and np.all(np.isfinite(cov)) else None,
        associations={vd.index: int(a) for vd, a in zip(problem.views, assoc) if a >= 0},
        semi_up=None if semi_up is None else float(semi_up),
        axis=np.array([float(x) for x in axis]) if lying else None,  # type: ignore[union-attr]  # lying: the long axis
        radius_std=radius_std if np.isfinite(radius_std) else None,
        n_views=int(n_views),
    )


def refine_and_check(
    problem: Problem,
    taken: Taken,
    centre0: NDArray[np.float64],
    radius0: float,
    assoc0: Sequence[int],
    semi_up0: float | None = None,
    axis: NDArray[np.float64] | None = None,
) -> Found | None:
    """Refine a hypothesis, re-associating its boxes among those not ``taken``; None unless it is accepted.

    Accepted: at least ``min_views`` associated views, a plausible radius and a
    score of at least ``accept`` nats. ``semi_up0``: the hypothesis is a spheroid, upright or along ``axis``.
    """
    cfg = problem.config
    fit = _refine_associating(problem, taken, centre0, float(radius0), list(assoc0), semi_up=semi_up0, axis=axis)
    if fit is not None and fit[1] < cfg.accept and sum(a >= 0 for a in fit[2]) > cfg.min_views:
        # A box cut by an unseen occluder can pull the least-squares fit off the position where the robust
        # score is best, and the object is then rejected although the other views agree. Refit without each
        # view in turn (its box then scores at that fit, or counts as a miss) and keep the best fit.
        refined, _, assoc = fit
        for v in [v for v, a in enumerate(assoc) if a >= 0]:
            without = [-1 if u == v else a for u, a in enumerate(assoc)]
            alt = _refine_associating(problem, taken, refined.centre, float(refined.radius), without, 1, refined.semi_up, axis)
            if alt is not None and alt[1] > fit[1]:
                fit = alt
    if fit is None:
        return None
    refined, score, assoc = fit
    n_views = sum(a >= 0 for a in assoc)
    if n_views < cfg.min_views or score < cfg.accept:
        return None
    return _object(problem, refined, score, assoc, n_views, axis)


def _refine_associating(
    problem: Problem,
    taken: Taken,
    centre: NDArray[np.float64],
    radius: float,
    assoc: list[int],
    rounds: int = 3,
    semi_up: float | None = None,
    axis: NDArray[np.float64] | None = None,
) -> tuple[Any, float, list[int]] | None:
    """Refine on the associated boxes, rescore (re-associating the free boxes) and repeat up to ``rounds`` times.

    Returns the refined sphere (or upright spheroid, with ``semi_up``), its score and the association it
    was scored with (None: too few views or an implausible size).
    """
    cfg = problem.config
    refined, score = None, -np.inf
    for _ in range(rounds):
        obs = observations(problem, assoc, centre)
        if len(obs) < cfg.min_views:
            return None
        refined = _refine(problem, obs, centre, radius, semi_up, axis)
        centre, radius, semi_up = refined.centre, refined.radius, refined.semi_up
        if not _radius_ok(problem, radius, semi_up):
            return None
        score, new_assoc = score_one(problem, taken, centre, radius, 0.0, semi_up, axis)
        if new_assoc == assoc:
            break
        assoc = new_assoc
    return (refined, score, assoc) if refined is not None else None


def fit_fixed(
    problem: Problem,
    centre0: NDArray[np.float64],
    radius0: float,
    assoc: Sequence[int],
    semi_up0: float | None = None,
    axis: NDArray[np.float64] | None = None,
) -> Found | None:
    """Refine one object with a fixed association and score it with that association (None: no valid fit).

    ``semi_up0``: a spheroid along ``axis`` (default ``up``)."""
    cfg, cam = problem.config, problem.camera
    obs = observations(problem, assoc, centre0)
    if len(obs) < cfg.min_views:
        return None
    refined = _refine(problem, obs, centre0, radius0, semi_up0, axis)
    if not _radius_ok(problem, refined.radius, refined.semi_up):
        return None
    score = 0.0
    b = refined.radius if refined.semi_up is None else refined.semi_up
    for v, (vd, j) in enumerate(zip(problem.views, assoc)):
        pred, visible, p_opt = shape_boxes(problem, v, refined.centre[None], np.array([refined.radius]), np.array([b]), [axis])
        if not visible[0]:
            continue
        s = (
            box_scores(pred[0], vd.boxes[j], problem.model, cam.width, cam.height, pose_px(problem, p_opt[0, 2]))
            if j >= 0
            else -np.inf
        )
        score += max(float(s), problem.model.miss_term)
    return _object(problem, refined, score - shape_cost(problem, refined.semi_up), assoc, len(obs), axis)


def associations_list(problem: Problem, obj: Found) -> list[int]:
    """An object's association as a list over ``problem.views`` (-1: none)."""
    return [obj.associations.get(vd.index, -1) for vd in problem.views]


def boxes_of(problem: Problem, obj: Found) -> set[tuple[int, int]]:
    """The ``(v, j)`` boxes an object holds."""
    return {(v, j) for v, j in enumerate(associations_list(problem, obj)) if j >= 0}


def held_boxes(problem: Problem, objects: Iterable[Found]) -> Taken:
    """The ``(v, j)`` boxes the ``objects`` hold: those the extraction and its repairs have explained."""
    return frozenset().union(*(boxes_of(problem, o) for o in objects))
