"""The steal pass: a fruit gets back the box a neighbour took, where the neighbour can do without it.

The greedy extraction can give a fruit the box of a neighbour that lost its own box in that view (occluded or missed):
the neighbour is then left with one view and never accepted. :func:`steal_pass` offers the search's hypotheses that
use a free box and a held one; the holders give up the held boxes (or take a free box of their own there) and the
move is kept where everything stays acceptable and the evidence grows by more than ``accept``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .hypotheses import last_level, same_place_m
from .likelihood import box_scores
from .problem import Problem
from .scoring import associations_list, boxes_of, fit_fixed, held_boxes, pose_px, predicted_boxes, refine_and_check
from .state import Found, Hypotheses, State, Taken

#: The steal pass tries one candidate per this many accepted objects (at least ``lookahead``): each try is local, and
#: with ``lookahead`` (3) tries for a whole scene a row of 128 fruit (``bench.scale.row_session(128, 5, 0)``) left a fruit
#: near its end without the box a neighbour took once the search's radii reached 160 mm and changed the order of the
#: candidates; the rows of 12-96 fruit and the accuracy benchmark's scenes keep their objects.
OBJECTS_PER_STEAL_CANDIDATE = 4


def _box_counts(problem: Problem, hyp: Hypotheses, taken: Taken) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Per grid hypothesis (scored with every box), its associated boxes that are free and that are in ``taken``,
    shapes (N, K)."""
    _, _, assoc0 = hyp.scores
    free_lut = [np.append(a, False) for a in problem.available(taken)]  # index -1 (no box) -> last slot
    held_lut = [np.append(~a, False) for a in problem.available(taken)]
    n_free = sum((f[a] for f, a in zip(free_lut, assoc0)), np.zeros(assoc0.shape[1:], dtype=np.int64))
    n_held = sum((h[a] for h, a in zip(held_lut, assoc0)), np.zeros(assoc0.shape[1:], dtype=np.int64))
    return n_free, n_held


def _steal_candidates(problem: Problem, hyp: Hypotheses, taken: Taken) -> NDArray[np.bool_]:
    """Grid hypotheses (scored with every box) using at least one free box and one taken box, shape (N, K)."""
    cfg = problem.config
    total0, n0, _ = hyp.scores
    n_free, n_held = _box_counts(problem, hyp, taken)
    return (total0 >= cfg.accept - cfg.tuning.prune_slack) & (n0 >= cfg.min_views) & (n_free >= 1) & (n_held >= 1)


def _replacement(problem: Problem, o: Found, v: int, free: NDArray[np.bool_], used: set[tuple[int, int]]) -> int:
    """The free box of view ``v`` (``free``: per box, whether nothing holds it; ``used``: boxes given away already)
    that best fits the prediction of ``o`` there within the sensor model's gate, or -1 (none)."""
    vd, cam = problem.views[v], problem.camera
    js = np.array([j for j in np.flatnonzero(free) if (v, int(j)) not in used], dtype=np.intp)
    if not len(js):
        return -1
    pred = predicted_boxes(problem, v, [o])[0][0]
    px = pose_px(problem, problem.depth(v, np.asarray(o.position, dtype=float)))
    s = box_scores(np.broadcast_to(pred, (len(js), 4)), vd.boxes[js], problem.model, cam.width, cam.height, px)
    best = int(np.argmax(s))
    return int(js[best]) if s[best] > problem.model.miss_term else -1


def _loser_refit(
    problem: Problem,
    o: Found,
    keep: list[int],
    lost: list[int],
    free: list[NDArray[np.bool_]],
    used: set[tuple[int, int]],
) -> tuple[Found | None, set[tuple[int, int]]]:
    """A holder refit without the boxes of views ``lost``, or with a free box of its own there instead (the box the
    candidate's neighbour would have had, left free when the extraction gave the holder the candidate's), whichever
    scores higher; and the free boxes it then takes."""
    plain = fit_fixed(problem, o.position, float(o.radius), keep, o.semi_up, o.axis)  # type: ignore[arg-type]
    swapped = list(keep)
    for v in lost:
        swapped[v] = _replacement(problem, o, v, free[v], used)
    extra = {(v, swapped[v]) for v in lost if swapped[v] >= 0}
    if not extra:
        return plain, set()
    alt = fit_fixed(problem, o.position, float(o.radius), swapped, o.semi_up, o.axis)  # type: ignore[arg-type]
    if alt is not None and (plain is None or alt.score > plain.score):
        return alt, extra
    return plain, set()


def _try_steal(
    problem: Problem,
    objects: list[Found],
    taken: Taken,
    holder: dict[tuple[int, int], int],
    centre: NDArray[np.float64],
    radius: float,
    wanted: list[int],
    semi_up: float | None = None,
    axis: NDArray[np.float64] | None = None,
) -> tuple[Found, dict[int, Found], set[tuple[int, int]]] | None:
    """The candidate refined with the boxes it wants (held ones released), the holders refit without them (or with a
    free box of their own in that view), and the free boxes those holders take."""
    cfg = problem.config
    stolen = {(v, j) for v, j in enumerate(wanted) if j >= 0 and (v, j) in holder}
    new = refine_and_check(problem, taken - stolen, centre, radius, wanted, semi_up, axis)
    if new is None:
        return None
    mine = boxes_of(problem, new)
    free = problem.available((taken - stolen) | mine)
    losers: dict[int, Found] = {}
    used: set[tuple[int, int]] = set()
    for i in sorted({holder[b] for b in mine if b in holder}):
        own = associations_list(problem, objects[i])
        lost = [v for v, j in enumerate(own) if (v, j) in mine]
        keep = [-1 if v in lost else j for v, j in enumerate(own)]
        refit, extra = _loser_refit(problem, objects[i], keep, lost, free, used)
        if refit is None or refit.score < cfg.accept:
            return None
        losers[i] = refit
        used |= extra
    if not losers:
        return None
    gain = new.score + sum(o.score for o in losers.values()) - sum(objects[i].score for i in losers)
    # a new object must pay for itself, as in the extraction: its score counts above ``accept``
    return (new, losers, used) if gain > cfg.accept else None


def steal_pass(problem: Problem, objects: list[Found], hyp: Hypotheses) -> list[Found]:
    """Give a fruit back the box a neighbour took when the neighbour can do without it.

    The greedy extraction can give a fruit the box of a neighbour that lost its
    own box in that view (occluded or missed): the neighbour is then left with
    one view and never accepted. Candidates are grid hypotheses (scored with
    every box available) that use at least one free box and at least one box
    an accepted object holds (where the extraction split the last search level
    lazily, that level is scored in the children of the cells using a free box:
    :func:`.search.last_level`). For the best of them (``lookahead``, or one per
    :data:`OBJECTS_PER_STEAL_CANDIDATE` objects if more), the holders
    give up those boxes and are refit without them, or with the free box that
    best fits their prediction in that view if that scores higher (the holder's
    own box, left free when the extraction gave it the candidate's), the
    candidate is refined with the boxes left to it, and the move is kept when
    both stay acceptable and the summed score grows by more than ``accept``.
    """
    cfg = problem.config
    taken = held_boxes(problem, objects)
    if not objects or hyp.scores[0].size == 0 or len(taken) == sum(len(vd.boxes) for vd in problem.views):
        return objects
    objects = list(objects)
    holder = {b: i for i, o in enumerate(objects) for b in boxes_of(problem, o)}
    if hyp.child_cell is not None:  # the extraction split the last level lazily: score it where a free box is
        hyp = last_level(problem, hyp, (_box_counts(problem, hyp, taken)[0] >= 1).any(axis=1))
    ok = _steal_candidates(problem, hyp, taken)
    total0, _, assoc0 = hyp.scores
    centres, radii = hyp.centres_base, hyp.radii
    tried = np.zeros(len(centres), dtype=bool)
    for _ in range(max(cfg.tuning.lookahead, len(objects) // OBJECTS_PER_STEAL_CANDIDATE)):
        sc = np.where(ok & ~tried[:, None], total0, -np.inf)
        if not np.isfinite(sc.max(initial=-np.inf)):
            break
        c, k = np.unravel_index(int(np.argmax(sc)), sc.shape)
        tried |= np.linalg.norm(centres - centres[c], axis=1) <= same_place_m(hyp.cell, float(radii[k]))
        wanted = [int(a) for a in assoc0[:, c, k]]
        b, u = hyp.bin_semi_up(int(k)), hyp.bin_axis(int(k))
        move = _try_steal(problem, objects, taken, holder, centres[c], float(radii[k]), wanted, b, u)
        if move is None:
            continue
        new, losers, replacements = move
        for i, o in losers.items():
            objects[i] = o
            holder.update({b: i for b in boxes_of(problem, o) & replacements})
        objects.append(new)
        mine = boxes_of(problem, new)
        taken = taken | mine | replacements
        holder.update({b: len(objects) - 1 for b in mine})
    return objects


def run(problem: Problem, state: State) -> State:
    """The pass: :func:`steal_pass` on the state's objects and the search's hypotheses."""
    assert state.hypotheses is not None
    return state.with_objects(steal_pass(problem, list(state.objects), state.hypotheses))
