"""Fitting and valuing objects and pairs with the shape models: the helpers every shape-aware pass shares.

An object's boxes are fitted with the shape models (sphere, spheroid, ellipsoid, and the solids: cylinder, cuboid)
by :func:`fitted_answer`, which keeps the lowest Bayesian information criterion; :func:`shape_value` values an
:data:`Answer` under the ``bayes`` sensor model (its box scores, occlusion and truncation included, less
``ln(edges) / 2`` per parameter), and :func:`beats` compares two. :func:`pair_values` values two objects side by side,
the edges one hides of the other left out; :func:`fit_value` values an object holding given boxes, a miss counted in
every view where it would be in the image without a box, within a :class:`Budget` of fits. The passes that move boxes
between objects (:mod:`.shape_swap`, :mod:`.second_look`, :mod:`.view_assign`) keep a move when it gains
:data:`MIN_GAIN_NATS`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...errors import InputError
from ...geometry.ellipsoid import Ellipsoid
from ...geometry.fit import fit_parameters, fit_shape_by_bic
from ...geometry.solids import SOLIDS
from .aspects import as_sphere, object_boxes, solid_boxes
from .box_sides import MEET_SIGMAS, ends_at_occluder, spans
from .likelihood import box_scores
from .problem import Problem
from .scoring import associations_list, boxes_of, pose_px
from .sensor import box_edge_sigma_px
from .solid_choice import solid_if_clear, solid_may_win
from .state import Found

#: Nats by which a swap of two objects' boxes in one view must raise their summed score: a chosen margin over the
#: refits' rounding, not a fitted value.
SWAP_GAIN_NATS = 1.0


#: Nats by which a move must beat the pair as the shape stage left it (the swap pass's, :data:`SWAP_GAIN_NATS`, doubled: the shape
#: models have more freedom to fit a wrong association than the search's spheres).
MIN_GAIN_NATS = 2.0 * SWAP_GAIN_NATS


#: Views an object needs before ``auto`` also tries the three-axis ellipsoid (it is weakly determined from fewer).
MIN_VIEWS_FOR_ELLIPSOID = 4


#: Views from which ``auto`` also fits the ellipsoid (upright axis, two horizontal semi-axes, yaw: 7 parameters), the
#: model of a lying object (a can, a box, a cucumber on its side), whose horizontal outline is not a circle. Three
#: views give 12 box edges, each a plane tangent to the object (a lying 5 x 5 x 12 cm object from three views:
#: tests/methods/bayes/test_bayes_shapes.py); the fit must then beat the first answer (:func:`beats`).
MIN_VIEWS_FOR_LYING = 3


#: Views from which ``solids`` also fits the yawed cuboid (7 parameters, as the ellipsoid; a square box's width changes
#: with the yaw from view to view, a cylinder's does not). From 3 views it is weakly determined and kept only with
#: clear evidence (:func:`.solid_choice.solid_evidence`), and still brings a box's centre closer than the ellipsoid
#: models do (why: docs/decisions/bayes-shapes.md#min_views_for_cuboid).
MIN_VIEWS_FOR_CUBOID = 3


#: Parameters of a sphere: centre and radius.
SPHERE_PARAMETERS = 4


#: The shape a solid reports: that of the ellipsoid with the same semi-axes (its radius or half-sides).
SOLID_SHAPES = {"cylinder": "spheroid", "cuboid": "ellipsoid"}


def sensor_scores(
    problem: Problem, poses: NDArray[np.float64], boxes: NDArray[np.float64], e: Ellipsoid, solid: str | None = None
) -> NDArray[np.float64]:
    """Log-likelihood ratio (nats) of each box (K, 4) seen from ``poses`` (K, 4, 4) given the ellipsoid ``e`` (the
    solid ``solid`` with its semi-axes, :func:`solid_boxes`): the ``bayes`` sensor model's box scores (occlusion and
    truncation included), a miss (``SensorModel.miss_term``: the box not explained) at worst, shape (K,)."""
    cam, model = problem.camera, problem.model
    pred, extra_sigma_px = predicted_boxes(problem, poses, e, solid)
    s = box_scores(pred, boxes, model, cam.width, cam.height, extra_sigma_px)
    return np.maximum(np.nan_to_num(np.asarray(s, dtype=float), nan=-np.inf), model.miss_term)


def predicted_boxes(
    problem: Problem, poses: NDArray[np.float64], e: Ellipsoid, solid: str | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The boxes (K, 4), pixels, the ellipsoid ``e`` (the solid ``solid``) has seen from ``poses`` (K, 4, 4,
    ``T_base_optical``), and the edge noise (K,), pixels, the stated pose uncertainty adds at its depth in each view
    (0 where poses are exact): what :func:`sensor_scores` scores the observed boxes against."""
    pred = solid_boxes(problem.camera, poses, e, solid)
    T_optical_base = np.linalg.inv(poses)
    depth = T_optical_base[:, 2, :3] @ e.centre_base + T_optical_base[:, 2, 3]
    return pred, np.asarray(pose_px(problem, depth), dtype=float)


def sensor_score(
    problem: Problem, poses: NDArray[np.float64], boxes: NDArray[np.float64], e: Ellipsoid, solid: str | None = None
) -> float:
    """:func:`sensor_scores` summed (nats)."""
    return float(np.sum(sensor_scores(problem, poses, boxes, e, solid)))


#: A shape answer of the stage: the object, its ellipsoid and its number of fitted parameters.
Answer = tuple[Found, Ellipsoid, int]


def beats(
    problem: Problem, obj: Found, new: Answer, old: Answer, n_edges: int, hidden_to: NDArray[np.float64] | None = None
) -> bool:
    """Whether the answer ``new`` is preferred to ``old`` by the Bayesian information criterion of the sensor model
    on ``obj``'s boxes: its log-likelihood ratio must exceed ``old``'s by more than ``ln(n_edges) / 2`` nats per
    extra parameter (fewer parameters lower the bar; :func:`evidence_margin` positive). The criterion of
    :func:`monovisual3d.geometry.fit.fit_shape_by_bic`, with the ``bayes`` sensor model (a cut box is occlusion
    there, at most ``inward_floor`` per edge) in place of Gaussian edges; the edges nearer objects hide no further
    than ``hidden_to`` scored as :func:`boxes_as_seen` says."""
    return evidence_margin(problem, obj, new, old, n_edges, hidden_to) > 0.0


def evidence_margin(
    problem: Problem, obj: Found, new: Answer, old: Answer, n_edges: int, hidden_to: NDArray[np.float64] | None = None
) -> float:
    """Nats by which ``new``'s log-likelihood ratio on ``obj``'s boxes exceeds ``old``'s beyond the BIC penalty of its
    extra parameters (:func:`beats`): the log of the Bayes factor for ``new`` that the BIC approximates."""
    gain = sensor_score(problem, *boxes_as_seen(problem, obj, new, hidden_to), new[1], new[0].solid)
    gain -= sensor_score(problem, *boxes_as_seen(problem, obj, old, hidden_to), old[1], old[0].solid)
    return gain - 0.5 * (new[2] - old[2]) * math.log(max(n_edges, 1))


def boxes_as_seen(
    problem: Problem, obj: Found, answer: Answer, hidden_to: NDArray[np.float64] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The poses (K, 4, 4) and boxes (K, 4), pixels, of :func:`object_boxes`, each edge a nearer object hides
    (``hidden_to`` (K, 4), pixels, finite: how far it may be hidden) moved to where ``answer`` predicts it within that
    range: a prediction between the observed edge and the limit costs nothing, one past the limit is scored from it,
    one inside the observed edge as before (a cut)."""
    poses, boxes = object_boxes(problem, obj)
    if hidden_to is None or not np.isfinite(hidden_to).any():
        return poses, boxes
    pred = solid_boxes(problem.camera, poses, answer[1], answer[0].solid)
    lo = np.maximum(np.minimum(pred[:, :2], boxes[:, :2]), hidden_to[:, :2])  # nan-propagating: seen edges stay
    hi = np.minimum(np.maximum(pred[:, 2:], boxes[:, 2:]), hidden_to[:, 2:])
    return poses, np.where(np.isfinite(hidden_to), np.concatenate([lo, hi], axis=1), boxes)


def sphere_answer(obj: Found) -> Answer:
    """:func:`as_sphere` as an :data:`Answer`: a sphere has 4 parameters."""
    o = as_sphere(obj)
    return o, Ellipsoid.sphere(o.position, float(o.radius)), SPHERE_PARAMETERS  # type: ignore[arg-type]


def _fit_options(
    problem: Problem, censored: NDArray[np.bool_] | None, hidden_to: NDArray[np.float64] | None
) -> dict[str, object]:
    """The options of :func:`~monovisual3d.geometry.fit.fit_ellipsoid_to_boxes` the shape stage fits with: the
    configuration's vertical, sizes and orientation, the sensor model's noise and border, the hidden edges."""
    cfg = problem.config
    return {
        "up": cfg.up_vector,
        "size_range": cfg.semi_axis_range,
        "box_sigma": problem.model.alpha,
        "edge_sigma_px": problem.model.sigma0_px,
        "border_px": problem.model.border_px,
        "free_orientation": cfg.free_orientation,
        "censored": censored,
        "hidden_to": hidden_to,
    }


def lowest_bic_fit(
    problem: Problem,
    obj: Found,
    shapes: tuple[str, ...],
    censored: NDArray[np.bool_] | None = None,
    search_sphere: bool = True,
    hidden_to: NDArray[np.float64] | None = None,
) -> tuple[Answer, int] | None:
    """The lowest-BIC fit of ``shapes`` to the object's boxes as an :data:`Answer` and the edges it used (None: too
    few usable edges), leaving out the ``censored`` edges (K, 4) (cut by nearer objects; in the order of
    :func:`object_boxes`), each hidden no further than ``hidden_to`` (K, 4), pixels, where given
    (:func:`~monovisual3d.geometry.fit.fit_ellipsoid_to_boxes`); under ``auto`` a sphere fit of an object the search
    found as a sphere gives the search's sphere (its refinement, with masks and pose noise, is the better sphere
    estimate) unless not ``search_sphere``.
    The solids among ``shapes`` are fitted after the ellipsoid models, where they could win
    (:func:`.solid_choice.solid_may_win`), and chosen by :func:`.solid_choice.solid_if_clear`."""
    cfg = problem.config
    poses, boxes = object_boxes(problem, obj)
    options = _fit_options(problem, censored, hidden_to)
    ellipsoids, solids = [s for s in shapes if s not in SOLIDS], [s for s in shapes if s in SOLIDS]
    if not ellipsoids:  # no ellipsoid model to weigh the solids against: fit them all
        ellipsoids, solids = list(shapes), []
    try:  # a model that cannot win is not fitted (a dense row's cut fruit): the same best
        _, fits = fit_shape_by_bic(problem.camera, poses, boxes, shapes=ellipsoids, every_model=False, **options)
    except InputError:
        return None
    for solid in solids:
        if solid_may_win(solid, fits, cfg.free_orientation, problem.model.sigma0_px):
            try:
                fits.update(fit_shape_by_bic(problem.camera, poses, boxes, shapes=(solid,), **options)[1])
            except InputError:
                continue
    best = solid_if_clear(min(fits.values(), key=lambda f: f.bic), fits)
    if search_sphere and best.model == "sphere" and cfg.shape == "auto" and obj.semi_up is None:
        return sphere_answer(obj), best.n_edges
    e = best.ellipsoid
    shape = SOLID_SHAPES.get(best.model, best.model)
    learned = {**obj.learned(), "shape_bic": float(best.bic), "shape_rms_px": float(best.rms_px)}
    learned["solid"] = best.model if shape != best.model else None
    o = Found(
        np.asarray(e.centre_base, dtype=float),
        obj.score,
        covariance=best.centre_covariance,
        associations=obj.associations,
        n_cells=obj.n_cells,
        shape=shape,
        semi_axes=np.asarray(e.semi_axes, dtype=float),
        quaternion_xyzw=np.asarray(e.quaternion_xyzw, dtype=float),
        **learned,
    )
    return (o, e, best.n_parameters), best.n_edges


def fitted_answer(
    problem: Problem,
    obj: Found,
    censored: NDArray[np.bool_] | None = None,
    shapes: tuple[str, ...] | None = None,
    hidden_to: NDArray[np.float64] | None = None,
) -> tuple[Answer, int] | None:
    """The lowest-BIC fit of ``shapes`` (default: every model ``auto`` may fit, upright and lying, the solids with
    ``BayesConfig.solids``) to the object's boxes as an :data:`Answer` with the edges it used (a sphere fitted, not
    the search's), the ``censored`` edges (K, 4) one-sided (only a prediction inside one costs; not counted as
    edges), each hidden no further than ``hidden_to`` (K, 4), pixels, where given; None: too few usable edges."""
    if shapes is None:
        shapes = every_shape(len(obj.associations), problem.config.solids)
    return lowest_bic_fit(problem, obj, shapes, censored, search_sphere=False, hidden_to=hidden_to)


def shape_value(
    problem: Problem, obj: Found, answer: Answer, n_edges: int, hidden_to: NDArray[np.float64] | None = None
) -> float:
    """The sensor model's log-likelihood ratio (nats) of the object's boxes given ``answer``, less ``ln(n_edges) / 2``
    per parameter: the Bayesian information criterion of :func:`beats`, as a value to compare associations by.

    ``hidden_to`` (K, 4), pixels, NaN where an edge is seen: an edge a nearer object hides, whose true place lies
    between the observed edge and this coordinate (the far side of the nearer box); a prediction there costs nothing,
    one beyond it is scored from it."""
    score = sensor_score(problem, *boxes_as_seen(problem, obj, answer, hidden_to), answer[1], answer[0].solid)
    return score - 0.5 * answer[2] * math.log(max(n_edges, 1))


def upright_shapes(n_views: int, solids: bool = False) -> tuple[str, ...]:
    """The models ``auto`` compares for an object elongated the same way in every view; with ``solids``
    (``BayesConfig.solids``) the upright solids too (a can, a bottle, a box)."""
    ellipsoids = ("sphere", "spheroid") + (("ellipsoid",) if n_views >= MIN_VIEWS_FOR_ELLIPSOID else ())
    return ellipsoids + (upright_solids(n_views) if solids else ())


def upright_solids(n_views: int) -> tuple[str, ...]:
    """The upright solids ``solids`` fits: a cylinder, and a cuboid with a yaw from :data:`MIN_VIEWS_FOR_CUBOID` views
    (a box lying on a table is one too: its sides are upright)."""
    return ("cylinder",) + (("cuboid",) if n_views >= MIN_VIEWS_FOR_CUBOID else ())


def every_shape(n_views: int, solids: bool) -> tuple[str, ...]:
    """Every model ``auto`` may fit from ``n_views`` views, upright and lying, the solids with ``solids``."""
    return tuple(dict.fromkeys(upright_shapes(n_views, solids) + lying_shapes(n_views)))


def lying_shapes(n_views: int) -> tuple[str, ...]:
    """The models ``auto`` compares for an object elongated both ways or wide (the ellipsoid from
    :data:`MIN_VIEWS_FOR_LYING` views)."""
    return ("sphere", "spheroid") + (("ellipsoid",) if n_views >= MIN_VIEWS_FOR_LYING else ())


def _fits(problem: Problem, objs: list[Found], shapes: tuple[str, ...] | None = None) -> list[tuple[Answer, int] | None]:
    """:func:`.shapes.fitted_answer` (of ``shapes``) of each object of a pair, refitted with the edges the other one
    hides censored."""
    fits = [fitted_answer(problem, o, shapes=shapes) for o in objs]
    if any(f is None for f in fits):
        return fits
    hidden = cut_by_each_other(problem, objs, [f[0][1] for f in fits])  # type: ignore[index]
    return [
        f if not np.isfinite(h).any() else fitted_answer(problem, o, np.isfinite(h), shapes, hidden_to=h)
        for o, f, h in zip(objs, fits, hidden)
    ]


def cut_by_each_other(problem: Problem, objs: list[Found], shapes: list[Ellipsoid]) -> list[NDArray[np.float64]]:
    """Per object of a pair, how far each of its edges (K, 4) (in the order of :func:`.aspects.object_boxes`) may be
    hidden: where the other, nearer there (by the centres of ``shapes``), spans it and has its box's facing edge at
    that edge (a box of the visible part, :func:`.occlusion.ends_at_occluder`), the nearer box's far side, pixels;
    NaN where the edge is seen."""
    held = [dict(o.associations) for o in objs]
    out = [np.full((len(h), 4), np.nan) for h in held]
    order = [sorted(h) for h in held]
    for v, vd in enumerate(problem.views):
        if vd.index not in held[0] or vd.index not in held[1]:
            continue
        depth = [problem.depth(v, e.centre_base) for e in shapes]
        near, far = (0, 1) if depth[0] < depth[1] else (1, 0)
        nb, fb = vd.boxes[held[near][vd.index]], vd.boxes[held[far][vd.index]]
        sigma = box_edge_sigma_px(problem.model, fb)
        cut = ends_at_occluder(fb, nb[None], 0.0, sigma) & spans(fb, nb, MEET_SIGMAS * sigma)[0, [0, 1, 0, 1]]
        out[far][order[far].index(vd.index)] = np.where(cut, nb, np.nan)
    return out


def pair_values(problem: Problem, objs: list[Found], shapes: tuple[str, ...] | None = None) -> tuple[list[float], list[Found]]:
    """The value (nats) of each of a pair holding what they hold under the models ``shapes`` (None: every model of the
    shape stage), the edges one hides of the other left out, and the pair as fitted (-inf each and the pair itself when
    one has no fit)."""
    fits = _fits(problem, objs, shapes)
    if any(f is None for f in fits):
        return [-math.inf] * len(objs), objs
    cut = cut_by_each_other(problem, objs, [f[0][1] for f in fits])  # type: ignore[index]
    values = [shape_value(problem, o, *f, hidden_to=c) for o, f, c in zip(objs, fits, cut)]  # type: ignore[misc]
    return values, [f[0][0] for f in fits]  # type: ignore[index]


def holding(problem: Problem, o: Found, assoc: list[int]) -> Found:
    """``o`` holding the boxes ``assoc`` (over ``problem.views``, -1: none) instead of its own."""
    held = {problem.views[v].index: j for v, j in enumerate(assoc) if j >= 0}
    return Found(o.position, o.score, o.radius, o.covariance, held, o.n_cells, **o.learned())


def as_answer(problem: Problem, o: Found) -> Answer:
    """An object of the shape stage as an :data:`.shapes.Answer` (its ellipsoid and number of parameters)."""
    model = o.solid or o.shape or "sphere"
    n = len(fit_parameters(model, free_orientation=problem.config.free_orientation))
    return o, Ellipsoid(o.position, o.semi_axes, o.quaternion_xyzw), n  # type: ignore[arg-type]


#: An object is hidden behind a nearer one's box when its predicted box lies inside it within this many of that box's
#: edge sigmas (:func:`.sensor.box_edge_sigma_px`), as two boxes meet in :mod:`.shape_swap`.
HIDDEN_SIGMAS = MEET_SIGMAS


def free_boxes(problem: Problem, objects: list[Found]) -> list[NDArray[np.intp]]:
    """Per view of ``problem.views``, the indices of the boxes no object holds."""
    held = set().union(*(boxes_of(problem, o) for o in objects))
    return [
        np.array([j for j in range(len(vd.boxes)) if (v, j) not in held], dtype=np.intp) for v, vd in enumerate(problem.views)
    ]


def hiders(problem: Problem, answer: Answer, assoc: list[int], occluders: Sequence[Found] = ()) -> list[int]:
    """Per view without a box where the answer's predicted box lies in the image and in front of the camera (in view
    order), the index of the one of ``occluders`` that hides it there (:func:`_hidden`), -1 where none does: a miss,
    which costs the sensor model's miss term."""
    empty = [v for v, j in enumerate(assoc) if j < 0]
    if not empty:
        return []
    poses = np.array([np.linalg.inv(problem.views[v].T_optical_base) for v in empty])
    pred = solid_boxes(problem.camera, poses, answer[1], answer[0].solid)
    depth = np.array([problem.depth(v, answer[1].centre_base) for v in empty])
    size = np.array([problem.camera.width, problem.camera.height], dtype=float)
    inside = (depth > 0) & np.all(pred[:, 2:] > 0, axis=1) & np.all(pred[:, :2] < size, axis=1)
    return [_hidden(problem, v, b, d, occluders) for v, b, d, i in zip(empty, pred, depth, inside) if i]


def misses(problem: Problem, answer: Answer, assoc: list[int], occluders: Sequence[Found] = ()) -> int:
    """The views of :func:`hiders` where no occluder hides the answer: each costs the sensor model's miss term."""
    return hiders(problem, answer, assoc, occluders).count(-1)


def _hidden(problem: Problem, v: int, box: NDArray[np.float64], depth: float, occluders: Sequence[Found]) -> int:
    """The index of the first of ``occluders`` that is nearer in view ``v`` than ``depth`` (metres) and holds a box
    there that the predicted box (4,), pixels, lies wholly inside, within :data:`HIDDEN_SIGMAS` of that box's edge
    noise: the object is hidden behind it, and a detector draws no box of it (two containers in line with the
    camera); -1: none."""
    for n, o in enumerate(occluders):
        j = associations_list(problem, o)[v]
        if j < 0 or problem.depth(v, o.position) >= depth:
            continue
        near = problem.views[v].boxes[j]
        tol = HIDDEN_SIGMAS * box_edge_sigma_px(problem.model, near)
        if np.all(box[:2] >= near[:2] - tol[:2]) and np.all(box[2:] <= near[2:] + tol[2:]):
            return n
    return -1


def _fitted_value(
    problem: Problem, seed: Found, assoc: list[int], occluders: Sequence[Found] = ()
) -> tuple[float, Found | None, list[int]]:
    """``seed`` holding the boxes ``assoc`` (over ``problem.views``), fitted with every shape model, its value (nats;
    -inf and None without a fit, or when the fit leaves a box it holds unexplained: a box scored as a miss is no part
    of the object) and its :func:`hiders` among ``occluders`` (each -1 a miss, counted in the value)."""
    obj = holding(problem, seed, assoc)
    fit = fitted_answer(problem, obj)
    if fit is None:
        return -np.inf, None, []
    answer, n_edges = fit
    poses, boxes = object_boxes(problem, obj)
    if np.any(sensor_scores(problem, poses, boxes, answer[1], answer[0].solid) <= problem.model.miss_term):
        return -np.inf, None, []
    behind = hiders(problem, answer, assoc, occluders)
    return shape_value(problem, answer[0], answer, n_edges) + behind.count(-1) * problem.model.miss_term, answer[0], behind


@dataclasses.dataclass
class Budget:
    """What a pass may still spend: shape fits (each with every model), and combinations of boxes to screen."""

    fits: int
    screened: int = 0

    def screen(self, n: float) -> bool:
        """Whether ``n`` more combinations may be screened (and count them)."""
        if n > self.screened:
            return False
        self.screened -= int(n)
        return True


def fit_value(
    problem: Problem, budget: Budget, seed: Found, assoc: list[int], occluders: Sequence[Found] = ()
) -> tuple[float, Found | None]:
    """:func:`_fitted_value` (value and fitted object) while the budget lasts (-inf and None after)."""
    return fit_hiders(problem, budget, seed, assoc, occluders)[:2]


def fit_hiders(
    problem: Problem, budget: Budget, seed: Found, assoc: list[int], occluders: Sequence[Found] = ()
) -> tuple[float, Found | None, list[int]]:
    """:func:`_fitted_value` while the budget lasts (-inf, None and no hiders after)."""
    if budget.fits <= 0:
        return -np.inf, None, []
    budget.fits -= 1
    return _fitted_value(problem, seed, assoc, occluders)


def others_than(objects: Sequence[Found], i: int) -> list[Found]:
    """``objects`` without the ``i``-th (all of them for ``i`` -1)."""
    return [o for k, o in enumerate(objects) if k != i]
