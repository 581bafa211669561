"""The swap pass: two objects that overlap in a view trade their boxes there, where both then fit better.

A fruit given the box of the fruit in front of it, and that fruit the other's: the greedy extraction takes the best
object first, with the boxes its hypothesis wanted. :func:`swap_pass` tries, in every view, each pair of objects whose
predicted boxes overlap there (gated: :func:`swap_worth_fitting`), refits both with their boxes traded, and keeps the
trade when their summed score grows by more than :data:`.fits.SWAP_GAIN_NATS`. The boxes held do not change.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .fits import SWAP_GAIN_NATS
from .likelihood import box_scores
from .problem import Problem
from .scoring import associations_list, fit_fixed, pose_px, predicted_boxes
from .state import Found, State


def _pair_gates(
    problem: Problem, v: int, objects: list[Found], boxes: NDArray[np.float64], rows: NDArray[np.intp]
) -> NDArray[np.bool_]:
    """Which pairs (``rows[i]``, ``j``) of ``objects`` (M) are worth a swap refit in view ``v``, shape (len(rows), M):
    their predicted ``boxes`` (M, 4) overlap with a positive area and :func:`swap_worth_fitting` says so."""
    b = boxes
    gate = (np.minimum(b[rows, None, 2], b[None, :, 2]) > np.maximum(b[rows, None, 0], b[None, :, 0])) & (
        np.minimum(b[rows, None, 3], b[None, :, 3]) > np.maximum(b[rows, None, 1], b[None, :, 1])
    )
    gate[np.arange(len(rows)), rows] = False
    r, c = np.nonzero(gate)
    if len(r):
        first, second = [objects[i] for i in rows[r]], [objects[j] for j in c]
        gate[r, c] = swap_worth_fitting(problem, v, first, second, boxes[rows[r]], boxes[c])
    return gate


#: Fits of :func:`fit_fixed` already made in a swap pass: (start position bytes, radius, semi-axis along the axis (and the
#: axis of a lying object), association) -> fit.
_Fits = dict[tuple[bytes, float, float | tuple[float, ...] | None, tuple[int, ...]], "Found | None"]


def _fit(problem: Problem, o: Found, assoc: list[int], fits: _Fits) -> Found | None:
    """``fit_fixed`` from ``o`` with ``assoc``, made once per pass (the pass's second round meets the same pairs)."""
    semi_up, axis = o.semi_up, o.axis
    shape = semi_up if axis is None else (semi_up, *axis.tolist())
    key = (np.asarray(o.position, dtype=np.float64).tobytes(), float(o.radius), shape, tuple(assoc))  # type: ignore[arg-type]
    if key not in fits:
        fits[key] = fit_fixed(problem, o.position, float(o.radius), assoc, semi_up, axis)  # type: ignore[arg-type]
    return fits[key]


def swap_worth_fitting(
    problem: Problem,
    v: int,
    first: list[Found],
    second: list[Found],
    first_boxes: NDArray[np.float64],
    second_boxes: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """Whether swapping the boxes of objects ``first[p]`` and ``second[p]`` (P pairs, predicted at ``first_boxes`` and
    ``second_boxes``, (P, 4)) in view ``v`` loses less than ``match_bonus`` nats at their current positions (the gate
    before the two refits), shape (P,) bool.

    A refit moves each object by a fraction of its box to fit the other views too; a swap that already costs
    more than a whole box's match where the objects stand is not recovered by that (on the accuracy benchmark's
    scenes and dense rows no swap beyond the gate was ever kept, and the gate skips 95 % of the refits).
    """
    vd, cam, model = problem.views[v], problem.camera, problem.model
    ja = np.array([associations_list(problem, a)[v] for a in first], dtype=np.intp)
    jb = np.array([associations_list(problem, b)[v] for b in second], dtype=np.intp)
    depth = [
        np.array([o.position for o in objs], dtype=float).reshape(-1, 3) @ vd.T_optical_base[2, :3] for objs in (first, second)
    ]
    sa, sb = (np.broadcast_to(pose_px(problem, d + vd.T_optical_base[2, 3]), d.shape) for d in depth)
    # per pair, 4 rows: a with its box, a with b's, b with its box, b with a's
    pred = np.stack([first_boxes, first_boxes, second_boxes, second_boxes], axis=1)
    which = np.stack([ja, jb, jb, ja], axis=1)
    px = np.stack([sa, sa, sb, sb], axis=1)
    s = box_scores(pred.reshape(-1, 4), vd.boxes[which.ravel()], model, cam.width, cam.height, px.ravel()).reshape(-1, 4)
    s = np.maximum(np.where(which >= 0, s, -np.inf), model.miss_term)
    return s[:, 1] + s[:, 3] >= s[:, 0] + s[:, 2] - model.match_bonus


def _try_swap(problem: Problem, v: int, a: Found, b: Found, fits: _Fits) -> tuple[Found, Found] | None:
    """``a`` and ``b`` refit with their boxes in view ``v`` swapped, if their summed score grows by more than :data:`SWAP_GAIN_NATS`."""
    assoc_a, assoc_b = associations_list(problem, a), associations_list(problem, b)
    assoc_a[v], assoc_b[v] = assoc_b[v], assoc_a[v]
    new_a = _fit(problem, a, assoc_a, fits)
    new_b = _fit(problem, b, assoc_b, fits)
    if new_a is None or new_b is None or new_a.score + new_b.score <= a.score + b.score + SWAP_GAIN_NATS:
        return None
    return new_a, new_b


def _swap_view(problem: Problem, v: int, objects: list[Found], fits: _Fits) -> bool:
    """One round of :func:`swap_pass` in view ``v``: the pairs in order, ``objects`` updated in place; whether any swapped."""
    holders = [i for i, o in enumerate(objects) if problem.views[v].index in o.associations]
    held = [objects[i] for i in holders]
    boxes = predicted_boxes(problem, v, held)[0]
    gate = _pair_gates(problem, v, held, boxes, np.arange(len(held)))  # symmetric; updated where objects change
    changed = False
    for pa, ia in enumerate(holders):
        pb = pa
        while len(later := np.flatnonzero(gate[pa, pb + 1 :])):  # the next partner worth a refit, as things are now
            pb += 1 + int(later[0])
            ib = holders[pb]
            swapped = _try_swap(problem, v, objects[ia], objects[ib], fits)
            if swapped is None:
                continue
            objects[ia], objects[ib] = held[pa], held[pb] = swapped
            boxes[[pa, pb]] = predicted_boxes(problem, v, list(swapped))[0]
            moved = np.array([pa, pb])
            gate[moved] = _pair_gates(problem, v, held, boxes, moved)
            gate[:, moved] = gate[moved].T
            changed = True
    return changed


def swap_pass(problem: Problem, objects: list[Found]) -> list[Found]:
    """Fix greedy association mistakes between fruit that overlap in a view (one hiding the other).

    For every view and every pair of objects whose predicted boxes overlap
    there, swap their boxes in that view, refit both, and keep the swap if
    their summed score grows by more than 1 nat. The set of taken boxes does
    not change.
    """
    objects = list(objects)
    fits: _Fits = {}
    for _ in range(2):
        changed = False
        for v in range(len(problem.views)):
            changed |= _swap_view(problem, v, objects, fits)
        if not changed:
            break
    return objects


def run(problem: Problem, state: State) -> State:
    """The pass: :func:`swap_pass` on the state's objects."""
    return state.with_objects(swap_pass(problem, list(state.objects)))
