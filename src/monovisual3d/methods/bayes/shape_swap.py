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
farther box ends at the nearer box's facing edge), refits with those edges hidden no further than the nearer box's
far side (the farther container cannot reach past it, or that part would show and its box would hold it), and values
the pair: the sensor model's box scores, a hidden edge costing nothing while the prediction stays behind the nearer
box, less the Bayesian information criterion's ``ln(edges) / 2`` per parameter (:func:`.shapes.shape_value`). The best
of these replaces the pair, fitted with every model of the shape stage, when it beats the pair as the shape stage left it by more than
:data:`MIN_GAIN_NATS`; where none does and the shape stage kept one of the pair as a sphere whose boxes are not round
(:func:`_cut_sphere`), the pair refitted with every model may. Plant rows, whose fruit are round, never pay for it.

``python benchmarks/container_pairs.py cuboid 0.005 500 503 0 --visible`` measures it (the module docstring there).

Then any two objects may trade one view's boxes where the geometry lets both still triangulate: after the trade, the
rays through each one's box centres meet at a point that projects near every box's centre (:func:`centres_agree_many`,
screened for all pairs at once by :func:`epipolar_trades`). From three distinct viewpoints that holds only for boxes
where the object projects; from two (three views, two of them close together) any two boxes on one epipolar line
pass, and two lying objects' boxes traded in the odd view make two sphere ghosts that the search and the sphere-level
swap pass cannot tell from the truth. The trade is judged with every shape model (the solids too: a lying box is an
upright cuboid) and must beat the pair both as the shape stage left it and refitted as it holds its boxes by
:data:`MIN_GAIN_NATS`. ``python benchmarks/tabletop_subsets.py 1000 1200 --two-viewpoints`` measures it; in a plant
row no trade passes the geometry (12-96 fruit: 0 of 3-450 screened pairs).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ...geometry.ellipsoid import Ellipsoid
from ...geometry.fit import fit_parameters
from .aspects import looks_round
from .associate import SWAP_GAIN_NATS
from .occlusion import ends_at_occluder, spans
from .problem import Problem
from .scoring import associations_list
from .sensor import box_edge_sigma_px
from .shapes import Answer, fitted_answer, shape_value
from .state import Found

#: Nats by which a move must beat the pair as the shape stage left it (the swap pass's, :data:`.associate.SWAP_GAIN_NATS`, doubled: the shape
#: models have more freedom to fit a wrong association than the search's spheres).
MIN_GAIN_NATS = 2.0 * SWAP_GAIN_NATS
#: The models that judge a trade: with the edges one object hides of the other left out, an upright spheroid fits a
#: container's remaining edges (its width's change with the view lies mostly in the hidden edges); the accepted trade's
#: objects are then fitted with every model of the shape stage.
TRADE_SHAPES = ("spheroid",)
#: Objects the pass looks at: upright ones at least this many times as tall as wide (a container, a bottle), whose box
#: width changes with the view where the object is not round in plan (a box), unlike the search's spheroids'; lying
#: objects have yawed hypotheses in the search already.
TALL_RATIO = 1.25
#: Two objects may trade a view's boxes, wherever they stand, when after the trade the rays through each one's box
#: centres meet at a point that projects within this fraction of each box's half-sizes of its centre: a whole box's
#: centre lies within a few per cent of its object's projection (perspective), and a cut of a fifth of the box moves it
#: by a quarter. With two distinct viewpoints any two boxes on one epipolar line pass; with three or more, only boxes
#: where the object projects.
CENTRE_TOLERANCE = 0.25
#: :func:`epipolar_trades` lets through a box up to this many times the two views' tolerances (:data:`CENTRE_TOLERANCE`
#: of the half-sizes' diagonal, as angles) off the epipolar line: the point of :func:`centres_agree` may lie that far
#: off either ray, seen from a view up to twice as far (a robot's views of one plant differ less; a fuzz of random
#: scenes 0.5-0.7 m away needed at most 1.5 with fy = 0.67 fx, 1.9 at 0.4-1.2 m).
SCREEN_MARGIN = 2.0
#: :func:`centres_agree_many` refuses rays whose normal matrix has a larger condition number: parallel rays (views
#: from one place) fix no point.
MAX_CONDITION = 1e12
#: Two cameras closer than this (metres) stand at one place: no epipolar line (:func:`epipolar_trades`).
SAME_PLACE_M = 1e-9
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


def _meets(problem: Problem, a: Found, b: Found) -> list[int]:
    """The views (indices into ``problem.views``) where the boxes ``a`` and ``b`` hold meet (:func:`boxes_meet`)."""
    ja, jb = associations_list(problem, a), associations_list(problem, b)
    views = problem.views
    return [
        v
        for v in range(len(views))
        if ja[v] >= 0 and jb[v] >= 0 and boxes_meet(problem, views[v].boxes[ja[v]], views[v].boxes[jb[v]])
    ]


def _fits(problem: Problem, objs: list[Found], shapes: tuple[str, ...] | None = TRADE_SHAPES) -> list[tuple[Answer, int] | None]:
    """:func:`.shapes.fitted_answer` (of ``shapes``) of each object of a pair, refitted with the edges the other one
    hides censored."""
    fits = [fitted_answer(problem, o, shapes=shapes) for o in objs]
    if any(f is None for f in fits):
        return fits
    hidden = _cut_by_each_other(problem, objs, [f[0][1] for f in fits])  # type: ignore[index]
    return [
        f if not np.isfinite(h).any() else fitted_answer(problem, o, np.isfinite(h), shapes, hidden_to=h)
        for o, f, h in zip(objs, fits, hidden)
    ]


def _cut_by_each_other(problem: Problem, objs: list[Found], shapes: list[Ellipsoid]) -> list[NDArray[np.float64]]:
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


def _value(problem: Problem, objs: list[Found], shapes: tuple[str, ...] | None = TRADE_SHAPES) -> tuple[float, list[Found]]:
    """The summed value (nats) of a pair holding what they hold under the models ``shapes``, and the pair as fitted
    (-inf and the pair itself when one has no fit)."""
    values, fitted = pair_values(problem, objs, shapes)
    return sum(values), fitted


def pair_values(problem: Problem, objs: list[Found], shapes: tuple[str, ...] | None = None) -> tuple[list[float], list[Found]]:
    """The value (nats) of each of a pair holding what they hold under the models ``shapes`` (None: every model of the
    shape stage), the edges one hides of the other left out, and the pair as fitted (-inf each and the pair itself when
    one has no fit)."""
    fits = _fits(problem, objs, shapes)
    if any(f is None for f in fits):
        return [-math.inf] * len(objs), objs
    cut = _cut_by_each_other(problem, objs, [f[0][1] for f in fits])  # type: ignore[index]
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


def _held_value(problem: Problem, objs: list[Found]) -> float:
    """The value (nats) of a pair as the shape stage left it, judged as :func:`_value` judges a fit."""
    answers = [as_answer(problem, o) for o in objs]
    cut = _cut_by_each_other(problem, objs, [a[1] for a in answers])
    n_edges = [4 * len(o.associations) for o in objs]
    return sum(shape_value(problem, o, a, n, hidden_to=c) for o, a, n, c in zip(objs, answers, n_edges, cut))


def _best_trade(
    problem: Problem,
    a: Found,
    b: Found,
    views: list[int],
    judge: tuple[str, ...] | None = TRADE_SHAPES,
    refit: bool = True,
) -> list[Found] | None:
    """``a`` and ``b`` as the shape models fit them, after the trade of one of ``views``'s boxes (or, with ``refit``,
    holding what they hold), whichever the models ``judge`` (None: every model) prefer by more than
    :data:`MIN_GAIN_NATS` to the pair as it is; None: none is. Without ``refit`` the pair refitted as it holds its boxes
    is a bar a trade must clear, not a move: a trade must win by the association, not by a refit. The winner, fitted
    with every model, must still beat the pair as it is by that margin. Where nothing wins and one of the pair is a cut
    sphere (:func:`_cut_sphere`), the pair refitted with every model may win by that margin."""
    ja, jb = associations_list(problem, a), associations_list(problem, b)
    bar = _held_value(problem, [a, b]) + MIN_GAIN_NATS
    best, best_pair, best_fitted = bar, None, None
    for v in [-1, *views] if refit else views:  # -1: no trade, the pair refitted
        ta, tb = list(ja), list(jb)
        if v >= 0:
            ta[v], tb[v] = jb[v], ja[v]
        pair = [holding(problem, a, ta), holding(problem, b, tb)]
        value, fitted = _value(problem, pair, judge)
        if value > best:
            best, best_pair, best_fitted = value, pair, fitted
    if best_pair is None and refit and judge is not None and any(_cut_sphere(problem, o) for o in (a, b)):
        value, fitted = _value(problem, [a, b], None)  # the screen cannot express what the sphere hides: every model
        return fitted if value > bar else None
    if best_pair is None or (not refit and _value(problem, [a, b], judge)[0] + MIN_GAIN_NATS >= best):
        return None
    if judge is None:  # already fitted with every model
        return best_fitted
    value, fitted = _value(problem, best_pair, None)
    return fitted if value > bar else None  # fitted with every model, the pair must still win


def _cut_sphere(problem: Problem, o: Found) -> bool:
    """Whether the shape stage kept ``o`` as the search's sphere though its boxes are not round (:func:`.aspects.looks_round`):
    the sensor model took them for cut by something unseen. Beside a tall object whose box ends them, the pair is
    refitted with every model when no spheroid move wins (:func:`_best_trade`): the spheroid screen cannot express a
    cuboid's box widths."""
    return o.shape == "sphere" and not looks_round(problem, o)


def is_tall(o: Found) -> bool:
    """Whether the shape stage made ``o`` an upright object at least :data:`TALL_RATIO` times as tall as it is wide
    (its third semi-axis is the vertical one)."""
    s = np.asarray(o.semi_axes, dtype=float) if o.semi_axes is not None else None
    return o.shape not in (None, "sphere") and s is not None and bool(s[2] >= TALL_RATIO * max(s[0], s[1]))


def centres_agree(problem: Problem, assoc: list[int]) -> bool:
    """Whether the rays through the centres of the boxes ``assoc`` (one per view of ``problem.views``, -1: none) meet
    as one object's do (:func:`centres_agree_many` of one association)."""
    return bool(centres_agree_many(problem, np.asarray(assoc, dtype=np.intp)[None])[0])


def centres_agree_many(problem: Problem, assocs: NDArray[np.intp]) -> NDArray[np.bool_]:
    """Per association (T, V) (a box index per view of ``problem.views``, -1: none; at least two views each), whether
    the rays through its boxes' centres meet as one object's do: their least-squares point lies in front of every
    camera and projects within :data:`CENTRE_TOLERANCE` of each box's half-sizes of its centre, shape (T,)."""
    point, ok, uv, half = _meeting_points(problem, assocs)
    held = assocs >= 0
    R = np.array([vd.T_optical_base[:3, :3] for vd in problem.views]).reshape(-1, 3, 3)
    t = np.array([vd.T_optical_base[:3, 3] for vd in problem.views]).reshape(-1, 3)
    p_optical = np.einsum("kij,tj->tki", R, point) + t[None]  # (T, V, 3)
    in_front = np.all((p_optical[..., 2] > 0) | ~held, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        offset = np.abs(problem.camera.project(p_optical) - uv)
    close = np.all(np.all(offset <= CENTRE_TOLERANCE * half, axis=2) | ~held, axis=1)
    return ok & in_front & close


def meeting_points(problem: Problem, assocs: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Per association (T, V) (a box index per view of ``problem.views``, -1: none), the point (T, 3), metres, base
    frame, closest to the rays through its boxes' centres, and whether the rays fix it (their normal matrix's condition
    number below :data:`MAX_CONDITION`), shape (T,)."""
    return _meeting_points(problem, assocs)[:2]


def _meeting_points(
    problem: Problem, assocs: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`meeting_points`, and the box centres and half-sizes (T, V, 2), pixels (0 and 1 where a view has none)."""
    n, n_views = assocs.shape
    held = assocs >= 0
    uv, half = np.zeros((n, n_views, 2)), np.ones((n, n_views, 2))
    d_base, eyes = np.zeros((n, n_views, 3)), np.zeros((n_views, 3))
    R = np.array([vd.T_optical_base[:3, :3] for vd in problem.views]).reshape(n_views, 3, 3)
    t = np.array([vd.T_optical_base[:3, 3] for vd in problem.views]).reshape(n_views, 3)
    for v, vd in enumerate(problem.views):
        b = vd.boxes[assocs[held[:, v], v]].reshape(-1, 4)
        uv[held[:, v], v], half[held[:, v], v] = 0.5 * (b[:, :2] + b[:, 2:]), 0.5 * (b[:, 2:] - b[:, :2])
        d_base[held[:, v], v] = problem.camera.rays(uv[held[:, v], v]) @ R[v]  # R^T d
        eyes[v] = -R[v].T @ t[v]
    P = (np.eye(3) - d_base[..., :, None] * d_base[..., None, :]) * held[..., None, None]  # projectors across the rays
    A, rhs = P.sum(axis=1), np.einsum("tkij,kj->ti", P, eyes)
    ok = np.all(np.isfinite(A), axis=(1, 2))
    ok[ok] = np.linalg.cond(A[ok]) < MAX_CONDITION
    point = np.zeros((n, 3))
    point[ok] = np.linalg.solve(A[ok], rhs[ok][..., None])[..., 0]
    return point, ok, uv, half


def epipolar_trades(problem: Problem, objects: list[Found]) -> NDArray[np.bool_]:
    """Which trades the epipolar geometry allows, shape (M, M, V): ``[i, k, v]`` where objects ``i`` and ``k`` both
    hold a box in view ``v`` and the centre of ``k``'s box there lies near the epipolar line of ``i``'s box centre in
    each other view ``i`` holds (within :data:`SCREEN_MARGIN` times the two boxes' :data:`CENTRE_TOLERANCE` of their
    half-sizes' diagonal; a camera at the same place as view ``v``'s says nothing), and the other way round: a screen,
    for every pair at once, that lets through the trades :func:`centres_agree` allows (all of them where no view sees
    the point from more than twice another's distance) and few others."""
    assoc = np.array([associations_list(problem, o) for o in objects], dtype=np.intp).reshape(len(objects), len(problem.views))
    n, n_views = assoc.shape
    rays, tol, eyes = np.zeros((n, n_views, 3)), np.zeros((n, n_views)), np.zeros((n_views, 3))
    for v, vd in enumerate(problem.views):
        R, t = vd.T_optical_base[:3, :3], vd.T_optical_base[:3, 3]
        eyes[v] = -R.T @ t
        held = assoc[:, v] >= 0
        b = vd.boxes[assoc[held, v]].reshape(-1, 4)
        rays[held, v] = problem.camera.rays(0.5 * (b[:, :2] + b[:, 2:])) @ R  # base frame
        half = 0.5 * np.hypot(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1])  # the half-sizes' diagonal
        tol[held, v] = CENTRE_TOLERANCE * half / min(problem.camera.fx, problem.camera.fy)
    ok = (assoc[:, None, :] >= 0) & (assoc[None, :, :] >= 0)
    for v in range(n_views):
        for u in range(n_views):
            baseline = eyes[v] - eyes[u]
            if u == v or np.linalg.norm(baseline) < SAME_PLACE_M:
                continue
            normal = np.cross(baseline, rays[:, u])  # (M, 3): the epipolar plane of i's ray in view u
            length = np.linalg.norm(normal, axis=1, keepdims=True)
            normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
            off = np.abs(normal @ rays[:, v].T)  # (M, M): sine of the angle of k's ray in v out of i's plane
            # the point the rays meet may lie off i's ray in u too, as seen from v up to twice as far
            ok[:, :, v] &= (assoc[:, u] < 0)[:, None] | (off <= SCREEN_MARGIN * (tol[None, :, v] + tol[:, u, None]))
    return ok & ok.transpose(1, 0, 2)


def _traded(problem: Problem, a: Found, b: Found, v: int) -> tuple[list[int], list[int]]:
    """The associations (over ``problem.views``) of ``a`` and ``b`` after they trade their boxes in view ``v``."""
    ta, tb = associations_list(problem, a), associations_list(problem, b)
    ta[v], tb[v] = tb[v], ta[v]
    return ta, tb


def shape_swap_pass(problem: Problem, objects: list[Found]) -> list[Found]:
    """Trade boxes between, or refit, pairs of objects side by side, one of them tall, where the shape models say so;
    then trade a view's boxes between pairs of objects that the geometry lets trade, where every shape model says so
    (the module docstring)."""
    return _distant_trades(problem, _tall_pairs(problem, list(objects)))


def _tall_pairs(problem: Problem, objects: list[Found]) -> list[Found]:
    """The pass over pairs side by side, one of them tall (:func:`is_tall`, :func:`boxes_meet`)."""
    tall = [is_tall(o) for o in objects]
    for i in range(len(objects)):
        for k in range(i + 1, len(objects)) if tall[i] else [k for k in np.flatnonzero(tall) if k > i]:
            shared = _meets(problem, objects[i], objects[k])
            traded = _best_trade(problem, objects[i], objects[k], shared) if shared else None
            if traded is not None:
                objects[i], objects[k] = traded
    return objects


def _distant_trades(problem: Problem, objects: list[Found]) -> list[Found]:
    """The pass over every pair whose trade of a view's boxes the box centres allow (:func:`epipolar_trades`, then
    :func:`centres_agree_many`); an object that traded is not offered another trade (its screen is stale)."""
    if len(objects) < 2:
        return objects
    upper = np.triu(np.ones((len(objects),) * 2, dtype=bool), 1)
    trades = np.argwhere(upper[:, :, None] & epipolar_trades(problem, objects))
    if len(trades) == 0:
        return objects
    assocs = np.array([x for i, k, v in trades for x in _traded(problem, objects[i], objects[k], v)], dtype=np.intp)
    trades = trades[centres_agree_many(problem, assocs).reshape(-1, 2).all(axis=1)]
    moved: set[int] = set()
    for i, k in sorted({(int(i), int(k)) for i, k, _ in trades}):
        if i in moved or k in moved:
            continue
        views = [int(v) for i2, k2, v in trades if (i2, k2) == (i, k)]
        traded = _best_trade(problem, objects[i], objects[k], views, None, refit=False)
        if traded is not None:
            objects[i], objects[k] = traded
            moved |= {i, k}
    return objects
