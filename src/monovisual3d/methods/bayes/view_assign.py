"""One view's boxes assigned afresh to the objects around a free box, each object judged from its other views.

The search, the swap passes and the second look move one box, or trade two objects' boxes, at a time. A chain of
trades in one view is none of these: two squat containers before a flat tray, seen from the side where the nearer
container's box lies inside the tray's, came out with container A holding B's box there, B holding the tray's, the
tray without a box in that view and A's own box free, with exact boxes and poses too. Each single move loses: A taking
its own free box leaves B's free, which the tray, seen twice, then takes
(why: docs/decisions/bayes-association.md#view_assign).

:func:`view_assignment` runs after the second look, on each view with a free box. The boxes there that overlap, a free
one among them, form a group; the objects holding them, and those without a box in the view whose predicted box meets
the group, are fitted from their other views (where a free box of the group, in place of what one of them holds, still
meets that one's other boxes: :func:`.shape_swap.centres_agree_many`; a false positive beside a fruit does not) (every model of the shape stage) and each predicts its box in the view.
Those predictions are assigned to the group's boxes, or to none, by the sensor model's box scores (a Hungarian
assignment). Where that differs from what the objects hold, each object is refitted holding its new boxes and the
objects together are valued as :mod:`.second_look` values an object (:func:`.second_look._fitted_value`: the box scores
less the information criterion's cost per parameter, a miss wherever an object would be in the image without a box);
the new assignment replaces the old when it is worth :data:`.shape_swap.MIN_GAIN_NATS` more than the objects refitted
as they were. At most :data:`MAX_FITS` shape fits in all, :data:`MAX_OBJECTS` objects a group.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

from .aspects import solid_boxes
from .fits import (
    MIN_GAIN_NATS,
    Answer,
    Budget,
    as_answer,
    fit_value,
    fitted_answer,
    free_boxes,
    holding,
    others_than,
    sensor_scores,
)
from .problem import Problem
from .rays import centres_agree_many
from .scoring import associations_list
from .state import Found, State

#: At most this many shape fits (each with every model, 10-50 ms) in one pass: a group of three objects costs nine (a
#: fit from the other views each, then each refitted as it held its boxes and as assigned), one of four twelve.
MAX_FITS = 12
#: Objects a group may concern; a larger group (a dense row's cluster) is left as it is.
MAX_OBJECTS = 4
#: An object is judged in a view from at least this many other views (two views fix a point).
MIN_OTHER_VIEWS = 2
#: Score of an assignment that cannot be (an object fitted from too few views, a box it cannot take), nats.
IMPOSSIBLE = -1e9


def _overlap(a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    """Whether two boxes (4,), pixels, overlap."""
    return bool(min(a[2], b[2]) > max(a[0], b[0]) and min(a[3], b[3]) > max(a[1], b[1]))


def _group(boxes: NDArray[np.float64], seed: int) -> list[int]:
    """The boxes (indices into ``boxes`` (M, 4)) joined to box ``seed`` by a chain of overlaps."""
    group, todo = {seed}, [seed]
    while todo:
        k = todo.pop()
        for j in range(len(boxes)):
            if j not in group and _overlap(boxes[k], boxes[j]):
                group.add(j)
                todo.append(j)
    return sorted(group)


def _pose(problem: Problem, v: int) -> NDArray[np.float64]:
    """View ``v``'s camera pose ``T_base_optical``, shape (1, 4, 4), as the box predictions take it."""
    return np.linalg.inv(problem.views[v].T_optical_base)[None]


def _judged_from_others(problem: Problem, o: Found, v: int, budget: Budget) -> Answer | None:
    """``o`` fitted (every model) from its boxes in the views other than ``v``; None from fewer than
    :data:`MIN_OTHER_VIEWS` views, without a fit, or when the budget is spent."""
    assoc = associations_list(problem, o)
    assoc[v] = -1
    if sum(j >= 0 for j in assoc) < MIN_OTHER_VIEWS or budget.fits <= 0:
        return None
    budget.fits -= 1
    fit = fitted_answer(problem, holding(problem, o, assoc))
    return None if fit is None else fit[0]


def view_assignment(problem: Problem, objects: list[Found]) -> list[Found]:
    """Objects around each free box reassigned that view's boxes where the shape models prefer it (module docstring)."""
    budget = Budget(fits=MAX_FITS)
    out = list(objects)
    for v, free in enumerate(free_boxes(problem, out)):
        boxes = problem.views[v].boxes
        done: set[int] = set()
        for f in free.tolist():
            if f in done:
                continue
            group = _group(boxes, f)
            done |= set(group)
            out = _reassigned(problem, out, v, group, budget, set(free.tolist()))
    return out


def _members(problem: Problem, objects: list[Found], v: int, group: list[int]) -> list[int]:
    """The objects a group of boxes in view ``v`` concerns: those holding one of them, and those without a box in the
    view, in front of the camera, whose box as the shape stage fitted it meets one."""
    boxes, pose = problem.views[v].boxes, _pose(problem, v)
    out = []
    for i, o in enumerate(objects):
        j = associations_list(problem, o)[v]
        if j >= 0 or o.semi_axes is None or problem.depth(v, o.position) <= 0:
            out += [i] if j in group else []
            continue
        _, e, _ = as_answer(problem, o)
        pred = solid_boxes(problem.camera, pose, e, o.solid)[0]
        if any(_overlap(pred, boxes[k]) for k in group):
            out.append(i)
    return out


def _free_box_fits_one(
    problem: Problem, objects: list[Found], members: list[int], v: int, group: list[int], free: set[int]
) -> bool:
    """Whether one of the group's free boxes, in place of what a member holds in view ``v``, still meets that member's
    other boxes (:func:`.shape_swap.centres_agree_many`): otherwise it is no member's (a false positive beside a fruit)
    and no assignment can give it to one."""
    assocs = []
    for i in members:
        for f in free.intersection(group):
            assoc = associations_list(problem, objects[i])
            assoc[v] = f
            if sum(j >= 0 for j in assoc) >= MIN_OTHER_VIEWS + 1:
                assocs.append(assoc)
    return bool(assocs) and bool(np.any(centres_agree_many(problem, np.array(assocs, dtype=np.intp))))


def _reassigned(problem: Problem, objects: list[Found], v: int, group: list[int], budget: Budget, free: set[int]) -> list[Found]:
    """``objects`` with the boxes of ``group`` in view ``v`` assigned afresh where that is worth it (module docstring)."""
    members = _members(problem, objects, v, group)
    if not members or len(members) > MAX_OBJECTS or not _free_box_fits_one(problem, objects, members, v, group, free):
        return objects
    boxes = problem.views[v].boxes
    poses = np.repeat(_pose(problem, v), len(group), axis=0)  # one per box of the group
    n = len(members)
    score = np.full((n, len(group) + n), IMPOSSIBLE)
    for r, i in enumerate(members):
        answer = _judged_from_others(problem, objects[i], v, budget)
        if answer is None:  # not judged: it keeps what it holds
            held = associations_list(problem, objects[i])[v]
            score[r, group.index(held) if held >= 0 else len(group) + r] = 0.0
            continue
        score[r, : len(group)] = sensor_scores(problem, poses, boxes[group], answer[1], answer[0].solid)
        score[r, len(group) + r] = problem.model.miss_term
    from scipy.optimize import linear_sum_assignment  # on first use: 0.45 s to import

    rows, cols = linear_sum_assignment(score, maximize=True)
    new = {members[r]: (group[c] if c < len(group) else -1) for r, c in zip(rows, cols)}
    changed = [i for i in members if associations_list(problem, objects[i])[v] != new[i]]
    if not changed or budget.fits < 2 * len(changed):
        return objects
    before, after, fitted = 0.0, 0.0, {}
    for i in changed:
        others = others_than(objects, i)
        assoc = associations_list(problem, objects[i])
        before += fit_value(problem, budget, objects[i], assoc, others)[0]
        assoc[v] = new[i]
        value, obj = fit_value(problem, budget, objects[i], assoc, others)
        if obj is None:
            return objects
        after += value
        fitted[i] = dataclasses.replace(obj, score=float(value))
    if not after > before + MIN_GAIN_NATS:
        return objects
    return [fitted.get(i, o) for i, o in enumerate(objects)]


def run(problem: Problem, state: State) -> State:
    """The pass: :func:`view_assignment` on the state's objects."""
    return state.with_objects(view_assignment(problem, list(state.objects)))
