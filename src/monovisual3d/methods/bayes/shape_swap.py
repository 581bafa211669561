"""Pair moves judged with the shape models: two objects side by side, one of them tall, trade a view's boxes, or are
refitted together, when the shapes fitted that way explain their boxes better.

The search, the extraction and the swap pass (:mod:`.associate`) compare associations with spheres and spheroids. A
box-shaped container is neither: its box width changes with the view by up to 41 % as the camera goes round it,
which no spheroid follows. Two such containers side by side, seen from about their height with boxes of their
visible parts (the farther box ends where the nearer one begins), then get an association or a fit that spheroids
prefer: the farther container's slivers of every view taken as one thin object and the nearer boxes as one fat
object, or a large sphere behind the nearer container, 20-60 mm off. With the edges that one container hides of the
other left out, the truth scores far better (three views: 35-36 nats against 18-30).

:func:`shape_swap_pass` runs after the shape stage, on every pair of objects at least one of which stands tall
(:func:`is_tall`: a container, a bottle) whose boxes stand side by side in a view (:func:`boxes_meet`). For the pair
as it holds its boxes and for each trade of one such view's boxes, it fits each object (:func:`.shapes.fitted_answer`,
the models :data:`TRADE_SHAPES`), finds the edges the nearer one hides of the other (:func:`_cut_by_each_other`: the
farther box ends at the nearer box's facing edge), refits with those edges left out, and values the pair: the sensor
model's box scores, a hidden edge costing nothing while the prediction stays behind the nearer box, less the Bayesian
information criterion's ``ln(edges) / 2`` per parameter (:func:`.shapes.shape_value`). The best of these replaces the
pair, fitted with every model of the shape stage, when it beats the pair as the shape stage left it by more than
:data:`MIN_GAIN_NATS`. Plant rows, whose fruit are round, never pay for it.

``python benchmarks/container_pairs.py cuboid 0.005 500 503 0 --visible`` measures it (the module docstring there).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ...geometry.ellipsoid import Ellipsoid
from ...geometry.fit import fit_parameters
from ...result import DetectedObject
from .occlusion import ends_at_occluder
from .problem import Problem
from .scoring import associations_list
from .sensor import box_edge_sigma_px
from .shapes import Answer, fitted_answer, shape_value

#: Nats by which a move must beat the pair as the shape stage left it (the swap pass's 1 nat, doubled: the shape
#: models have more freedom to fit a wrong association than the search's spheres).
MIN_GAIN_NATS = 2.0
#: The models that judge a trade: with the edges one object hides of the other left out, an upright spheroid fits a
#: container's remaining edges (its width's change with the view lies mostly in the hidden edges); the accepted trade's
#: objects are then fitted with every model of the shape stage.
TRADE_SHAPES = ("spheroid",)
#: Objects the pass looks at: upright ones at least this many times as tall as wide (a container, a bottle), whose box
#: width changes with the view where the object is not round in plan (a box), unlike the search's spheroids'; lying
#: objects have yawed hypotheses in the search already.
TALL_RATIO = 1.25
#: Boxes of two objects stand side by side when they share at least this fraction of the lower one's height.
MIN_SHARED_HEIGHT = 0.5
#: Boxes of two objects meet in a view when they overlap, or when their facing edges are within this many edge sigmas.
MEET_SIGMAS = 2.0


def boxes_meet(problem: Problem, a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    """Whether two observed boxes (4,), pixels, stand side by side as one object hiding part of another does: they
    share at least :data:`MIN_SHARED_HEIGHT` of the lower one's height and overlap, or abut within :data:`MEET_SIGMAS`
    edge sigmas (of the narrower one), across."""
    shared = min(a[3], b[3]) - max(a[1], b[1])
    if shared < MIN_SHARED_HEIGHT * min(a[3] - a[1], b[3] - b[1]):
        return False
    sigma = float(np.min(box_edge_sigma_px(problem.model, np.stack([a, b]))[:, 0]))
    return bool(min(a[2], b[2]) - max(a[0], b[0]) > -MEET_SIGMAS * sigma)


def _meets(problem: Problem, a: DetectedObject, b: DetectedObject) -> list[int]:
    """The views (indices into ``problem.views``) where the boxes ``a`` and ``b`` hold meet (:func:`boxes_meet`)."""
    ja, jb = associations_list(problem, a), associations_list(problem, b)
    views = problem.views
    return [
        v
        for v in range(len(views))
        if ja[v] >= 0 and jb[v] >= 0 and boxes_meet(problem, views[v].boxes[ja[v]], views[v].boxes[jb[v]])
    ]


def _fits(
    problem: Problem, objs: list[DetectedObject], shapes: tuple[str, ...] | None = TRADE_SHAPES
) -> list[tuple[Answer, int] | None]:
    """:func:`.shapes.fitted_answer` (of ``shapes``) of each object of a pair, refitted with the edges the other one
    hides censored."""
    fits = [fitted_answer(problem, o, shapes=shapes) for o in objs]
    if any(f is None for f in fits):
        return fits
    hidden = _cut_by_each_other(problem, objs, [f[0][1] for f in fits])  # type: ignore[index]
    cut = [np.isfinite(h) for h in hidden]
    return [f if not c.any() else fitted_answer(problem, o, c, shapes) for o, f, c in zip(objs, fits, cut)]


def _cut_by_each_other(problem: Problem, objs: list[DetectedObject], shapes: list[Ellipsoid]) -> list[NDArray[np.float64]]:
    """Per object of a pair, how far each of its edges (K, 4) (in the order of :func:`.shapes.object_boxes`) may be
    hidden: where the other, nearer there (by the centres of ``shapes``), spans it and has its box's facing edge at
    that edge (a box of the visible part, :func:`.occlusion.ends_at_occluder`), the nearer box's far side, pixels;
    NaN where the edge is seen."""
    held = [dict(o.associations) for o in objs]
    out = [np.full((len(h), 4), np.nan) for h in held]
    order = [sorted(h) for h in held]
    for vd in problem.views:
        if vd.index not in held[0] or vd.index not in held[1]:
            continue
        depth = [float(vd.T_optical_base[2, :3] @ e.centre_base + vd.T_optical_base[2, 3]) for e in shapes]
        near, far = (0, 1) if depth[0] < depth[1] else (1, 0)
        nb, fb = vd.boxes[held[near][vd.index]], vd.boxes[held[far][vd.index]]
        sigma = box_edge_sigma_px(problem.model, fb)
        tol = MEET_SIGMAS * sigma
        spans = np.array(
            [nb[1] <= fb[1] + tol[1] and nb[3] >= fb[3] - tol[3], nb[0] <= fb[0] + tol[0] and nb[2] >= fb[2] - tol[2]]
        )
        cut = ends_at_occluder(fb, nb[None], 0.0, sigma) & spans[[0, 1, 0, 1]]
        out[far][order[far].index(vd.index)] = np.where(cut, nb, np.nan)
    return out


def _value(
    problem: Problem, objs: list[DetectedObject], shapes: tuple[str, ...] | None = TRADE_SHAPES
) -> tuple[float, list[DetectedObject]]:
    """The summed value (nats) of a pair holding what they hold under the models ``shapes``, and the pair as fitted
    (-inf and the pair itself when one has no fit)."""
    total = 0.0
    fits = _fits(problem, objs, shapes)
    if any(f is None for f in fits):
        return -math.inf, objs
    cut = _cut_by_each_other(problem, objs, [f[0][1] for f in fits])  # type: ignore[index]
    for o, f, c in zip(objs, fits, cut):
        total += shape_value(problem, o, *f, hidden_to=c)  # type: ignore[misc]
    return total, [f[0][0] for f in fits]  # type: ignore[index]


def _holding(problem: Problem, o: DetectedObject, assoc: list[int]) -> DetectedObject:
    """``o`` holding the boxes ``assoc`` (over ``problem.views``, -1: none) instead of its own."""
    held = {problem.views[v].index: j for v, j in enumerate(assoc) if j >= 0}
    return DetectedObject(o.position, o.score, o.radius, o.covariance, held, o.n_cells, o.extra)


def _as_answer(problem: Problem, o: DetectedObject) -> Answer:
    """An object of the shape stage as an :data:`.shapes.Answer` (its ellipsoid and number of parameters)."""
    model = o.extra.get("solid") or o.shape or "sphere"
    n = len(fit_parameters(model, free_orientation=problem.config.free_orientation))
    return o, Ellipsoid(o.position, o.semi_axes, o.quaternion_xyzw), n  # type: ignore[arg-type]


def _held_value(problem: Problem, objs: list[DetectedObject]) -> float:
    """The value (nats) of a pair as the shape stage left it, judged as :func:`_value` judges a fit."""
    answers = [_as_answer(problem, o) for o in objs]
    cut = _cut_by_each_other(problem, objs, [a[1] for a in answers])
    n_edges = [4 * len(o.associations) for o in objs]
    return sum(shape_value(problem, o, a, n, hidden_to=c) for o, a, n, c in zip(objs, answers, n_edges, cut))


def _best_trade(problem: Problem, a: DetectedObject, b: DetectedObject, shared: list[int]) -> list[DetectedObject] | None:
    """``a`` and ``b`` as the shape models fit them, holding what they hold or after the trade of one shared view's
    boxes, whichever those models prefer by more than :data:`MIN_GAIN_NATS` to the pair as it is; None: none is."""
    ja, jb = associations_list(problem, a), associations_list(problem, b)
    best, best_pair = _held_value(problem, [a, b]) + MIN_GAIN_NATS, None
    for v in [-1, *shared]:  # -1: no trade, the pair refitted
        ta, tb = list(ja), list(jb)
        if v >= 0:
            ta[v], tb[v] = jb[v], ja[v]
        pair = [_holding(problem, a, ta), _holding(problem, b, tb)]
        value = _value(problem, pair)[0]
        if value > best:
            best, best_pair = value, pair
    if best_pair is None:
        return None
    value, fitted = _value(problem, best_pair, None)
    return fitted if value > -math.inf else None


def is_tall(o: DetectedObject) -> bool:
    """Whether the shape stage made ``o`` an upright object at least :data:`TALL_RATIO` times as tall as it is wide
    (its third semi-axis is the vertical one)."""
    s = np.asarray(o.semi_axes, dtype=float) if o.semi_axes is not None else None
    return o.shape not in (None, "sphere") and s is not None and bool(s[2] >= TALL_RATIO * max(s[0], s[1]))


def shape_swap_pass(problem: Problem, objects: list[DetectedObject]) -> list[DetectedObject]:
    """Trade boxes between, or refit, pairs of objects side by side, one of them tall, where the shape models say so
    (the module docstring)."""
    objects = list(objects)
    tall = [is_tall(o) for o in objects]
    for i in range(len(objects)):
        for k in range(i + 1, len(objects)) if tall[i] else [k for k in np.flatnonzero(tall) if k > i]:
            shared = _meets(problem, objects[i], objects[k])
            traded = _best_trade(problem, objects[i], objects[k], shared) if shared else None
            if traded is not None:
                objects[i], objects[k] = traded
    return objects
