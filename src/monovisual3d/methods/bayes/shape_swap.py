"""Pair moves judged with the shape models: two objects side by side, one of them tall, trade a view's boxes, or are
refitted together, when the shapes fitted that way explain their boxes better.

The search, the extraction and the swap pass (:mod:`.swap`) compare associations with spheres and spheroids. A
box-shaped container is neither: its box width changes with the view by up to 41 % as the camera goes round it,
which no spheroid follows. Two such containers side by side, seen from about their height with boxes of their
visible parts (the farther box ends where the nearer one begins), then get an association or a fit that spheroids
prefer: the farther container's slivers of every view taken as one thin object and the nearer boxes as one fat
object, or a large sphere behind the nearer container, 20-60 mm off. With the edges that one container hides of the
other left out, the truth scores far better (three views: 35-36 nats against 18-30).

:func:`shape_swap_pass` runs after the shape stage, on every pair of objects at least one of which stands tall
(:func:`is_tall`: a container, a bottle) whose boxes stand side by side in a view (:func:`boxes_meet`). For the pair
as it holds its boxes and for each trade of one such view's boxes, it fits each object (:func:`.shapes.fitted_answer`,
the models :data:`TRADE_SHAPES`), finds the edges the nearer one hides of the other (:func:`cut_by_each_other`: the
farther box ends at the nearer box's facing edge), refits with those edges hidden no further than the nearer box's
far side (the farther container cannot reach past it, or that part would show and its box would hold it), and values
the pair: the sensor model's box scores, a hidden edge costing nothing while the prediction stays behind the nearer
box, less the Bayesian information criterion's ``ln(edges) / 2`` per parameter (:func:`.shapes.shape_value`). The best
of these replaces the pair, fitted with every model of the shape stage, when it beats the pair as the shape stage left it by more than
:data:`MIN_GAIN_NATS`; where none does and the shape stage kept one of the pair as a sphere whose boxes are not round
(:func:`_cut_sphere`), the pair refitted with every model may. Plant rows, whose fruit are round, never pay for it
(why: docs/decisions/bayes-association.md#shape_swap).

Then any two objects may trade one view's boxes where the geometry lets both still triangulate: after the trade, the
rays through each one's box centres meet at a point that projects near every box's centre (:func:`centres_agree_many`,
screened for all pairs at once by :func:`epipolar_trades`). From three distinct viewpoints that holds only for boxes
where the object projects; from two (three views, two of them close together) any two boxes on one epipolar line
pass, and two lying objects' boxes traded in the odd view make two sphere ghosts that the search and the sphere-level
swap pass cannot tell from the truth. The trade is judged with every shape model (the solids too: a lying box is an
upright cuboid) and must beat the pair both as the shape stage left it and refitted as it holds its boxes by
:data:`MIN_GAIN_NATS`. In a plant row no trade passes the geometry
(why: docs/decisions/bayes-association.md#epipolar-trades).
"""

from __future__ import annotations

import numpy as np

from .aspects import looks_round
from .box_sides import boxes_meet
from .fits import MIN_GAIN_NATS, as_answer, cut_by_each_other, holding, pair_values, shape_value
from .problem import Problem
from .rays import centres_agree_many, epipolar_trades
from .scoring import associations_list
from .state import Found, State

#: The models that judge a trade: with the edges one object hides of the other left out, an upright spheroid fits a
#: container's remaining edges (its width's change with the view lies mostly in the hidden edges); the accepted trade's
#: objects are then fitted with every model of the shape stage.
TRADE_SHAPES = ("spheroid",)
#: Objects the pass looks at: upright ones at least this many times as tall as wide (a container, a bottle), whose box
#: width changes with the view where the object is not round in plan (a box), unlike the search's spheroids'; lying
#: objects have yawed hypotheses in the search already.
TALL_RATIO = 1.25


def _meets(problem: Problem, a: Found, b: Found) -> list[int]:
    """The views (indices into ``problem.views``) where the boxes ``a`` and ``b`` hold meet (:func:`boxes_meet`)."""
    ja, jb = associations_list(problem, a), associations_list(problem, b)
    views = problem.views
    return [
        v
        for v in range(len(views))
        if ja[v] >= 0 and jb[v] >= 0 and boxes_meet(problem.model, views[v].boxes[ja[v]], views[v].boxes[jb[v]])
    ]


def _value(problem: Problem, objs: list[Found], shapes: tuple[str, ...] | None = TRADE_SHAPES) -> tuple[float, list[Found]]:
    """The summed value (nats) of a pair holding what they hold under the models ``shapes``, and the pair as fitted
    (-inf and the pair itself when one has no fit)."""
    values, fitted = pair_values(problem, objs, shapes)
    return sum(values), fitted


def _held_value(problem: Problem, objs: list[Found]) -> float:
    """The value (nats) of a pair as the shape stage left it, judged as :func:`_value` judges a fit."""
    answers = [as_answer(problem, o) for o in objs]
    cut = cut_by_each_other(problem, objs, [a[1] for a in answers])
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


def run(problem: Problem, state: State) -> State:
    """The pass: :func:`shape_swap_pass` on the state's objects."""
    return state.with_objects(shape_swap_pass(problem, list(state.objects)))
