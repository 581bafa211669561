"""Objects whose boxes belong to several fruit: regrouped with their neighbours when that explains the boxes better.

Three rays through boxes of three different fruit can meet in front of or behind the plant, and the object there
explains them like a fruit seen three times: the greedy extraction takes it first when it scores best (seed 7552 of
the false-positive greenhouse condition: 22.9 nats, 0.14 m in front of the plant). Each fruit that gave it a box is
then left with two views and either lost or paired with another fruit's box; no steal or swap move undoes that, as
each leaves a holder with one box.

:func:`regroup_pass` takes each object in turn and the best hypotheses of the search that use one of its boxes with
another association. The object and the holders of the boxes those hypotheses want give up their boxes; the boxes so
released, with the free ones, are extracted again greedily with the object's own association banned; the new objects
replace the old ones when their summed score above ``accept`` is higher (each object pays ``accept``, as in the
extraction, so that splitting evidence into more objects is not free).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ...result import DetectedObject
from .problem import Problem, Taken
from .scoring import associations_list, boxes_of, refine_and_check
from .search import Hypotheses

#: Hypotheses tried per object (the best, at distinct places) to find the objects to regroup with it.
CANDIDATES_PER_OBJECT = 3

Box = tuple[int, int]


@dataclass(frozen=True)
class _Table:
    """The search's hypotheses that could be objects (enough views, a score near ``accept``), flattened, with the
    hypotheses using each box (so that every step below costs in proportion to the hypotheses on the boxes it touches,
    not to the whole table: linear in the fruit of a row).

    ``score`` (n,) nats, ``assoc`` (V, n) box per view (-1: none), ``cell`` and ``bin`` (n,) their indices in
    ``hyp``; ``order[v]`` the hypotheses sorted by their box in view ``v``, ``start[v][j]`` where box ``j``'s begin.
    """

    score: NDArray[np.float64]
    assoc: NDArray[np.int32]
    cell: NDArray[np.intp]
    bin: NDArray[np.intp]
    order: list[NDArray[np.intp]]
    start: list[NDArray[np.intp]]

    @classmethod
    def of(cls, problem: Problem, hyp: Hypotheses) -> _Table:
        cfg = problem.config
        total, n_assoc, assoc = hyp.scores
        flat = np.flatnonzero((n_assoc >= cfg.min_views) & (total >= cfg.accept - cfg.prune_slack))
        cell, k = np.divmod(flat, total.shape[1])
        assoc = assoc.reshape(len(assoc), -1)[:, flat]
        return cls.build(total.reshape(-1)[flat], assoc, cell, k, [len(vd.boxes) for vd in problem.views])

    @classmethod
    def build(
        cls, score: NDArray[np.float64], assoc: NDArray[np.int32], cell: NDArray[np.intp], k: NDArray[np.intp], n_boxes: list[int]
    ) -> _Table:
        """The table of ``score`` (n,), ``assoc`` (V, n), ``cell`` and ``k`` (n,), with ``n_boxes`` boxes per view."""
        order = [np.argsort(a, kind="stable") for a in assoc]
        start = [np.searchsorted(a[o], np.arange(n + 1)) for a, o, n in zip(assoc, order, n_boxes)]
        return cls(score, assoc, cell, k, order, start)

    def users(self, boxes: set[Box]) -> NDArray[np.intp]:
        """The hypotheses (indices, sorted) that use at least one of ``boxes``."""
        parts = [self.order[v][self.start[v][j] : self.start[v][j + 1]] for v, j in boxes]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=np.intp)

    def using(self, boxes: set[Box], among: NDArray[np.intp]) -> NDArray[np.int64]:
        """How many of ``boxes`` each hypothesis of ``among`` uses."""
        count = np.zeros(len(among), dtype=np.int64)
        for v, j in boxes:
            count += self.assoc[v, among] == j
        return count


def _grid_worth_of(problem: Problem, table: _Table, objects: list[DetectedObject]) -> float:
    """The summed grid score above ``accept`` of the best hypotheses with exactly the objects' associations (nats;
    NaN where the table has none: the refinement re-associated the object)."""
    worth = 0.0
    for o in objects:
        own = associations_list(problem, o)
        near = table.users({next(iter(boxes_of(problem, o)))})
        same = near[np.all(table.assoc[:, near] == np.asarray(own)[:, None], axis=0)]
        worth += float(table.score[same].max()) - problem.config.accept if len(same) else np.nan
    return worth


def _grid_worth_again(table: _Table, live: NDArray[np.intp], accept: float) -> float:
    """The summed grid score above ``accept`` of a greedy extraction from the hypotheses ``live`` (nats), no
    refinement: each step takes the best and drops those sharing a box with it."""
    worth = 0.0
    while len(live):
        h = live[np.argmax(table.score[live])]
        if table.score[h] < accept:
            break
        worth += float(table.score[h]) - accept
        live = live[~np.any((table.assoc[:, live] == table.assoc[:, h : h + 1]) & (table.assoc[:, h : h + 1] >= 0), axis=0)]
    return worth


def _worth(objects: list[DetectedObject], accept: float) -> float:
    """The summed score above ``accept`` of ``objects`` (nats)."""
    return float(sum(o.score - accept for o in objects))


def _group(problem: Problem, hyp: Hypotheses, table: _Table, obj: DetectedObject, holders: dict[Box, int]) -> set[int]:
    """The holders (indices, from ``holders``: box -> object) of the boxes that the best hypotheses on ``obj``'s
    boxes with another association, at distinct places, want."""
    own = np.asarray(associations_list(problem, obj))
    cand = table.users(boxes_of(problem, obj))
    cand = cand[~np.all(table.assoc[:, cand] == own[:, None], axis=0)]
    centres = hyp.centres_base[table.cell[cand]]
    group: set[int] = set()
    for _ in range(CANDIDATES_PER_OBJECT):
        if len(cand) == 0:
            break
        best = int(np.argmax(table.score[cand]))
        h = cand[best]
        group |= {holders[(v, int(j))] for v, j in enumerate(table.assoc[:, h]) if (v, int(j)) in holders}
        near = np.linalg.norm(centres - centres[best], axis=1) <= max(2 * hyp.cell, float(hyp.radii[table.bin[h]]))
        cand, centres = cand[~near], centres[~near]
    return group


def _reextract(
    problem: Problem,
    hyp: Hypotheses,
    table: _Table,
    pool: set[Box],
    released: set[Box],
    banned: set[Box],
    taken: Taken,
    old_grid_worth: float,
) -> list[DetectedObject]:
    """Objects extracted greedily from the boxes in ``pool`` (the rest stay ``taken``), each from a hypothesis using a
    ``released`` box (those on free boxes alone the extraction refused already), none holding exactly ``banned``.

    Nothing where the same greedy extraction on the grid's scores falls more than ``lookahead_margin`` below
    ``old_grid_worth``, the objects' own grid worth (:func:`_grid_worth_of`): the refinement would not close
    that gap (as the extraction's look-ahead refines only candidates that close to the best)."""
    cfg = problem.config
    live = table.users(released)
    live = live[table.using(pool, live) >= cfg.min_views]
    banned_row = np.full(len(table.assoc), -1)
    for v, j in banned:
        banned_row[v] = j
    live = live[~np.all(table.assoc[:, live] == banned_row[:, None], axis=0)]
    if _grid_worth_again(table, live, cfg.accept) < old_grid_worth - cfg.lookahead_margin:
        return []  # on the grid, the regrouping explains the boxes clearly worse: not worth refining
    out: list[DetectedObject] = []
    pool = set(pool)
    while len(live):
        order = live[np.argsort(-table.score[live], kind="stable")[: cfg.lookahead]]
        order = order[table.score[order] >= table.score[order[0]] - cfg.lookahead_margin]
        best: DetectedObject | None = None
        for h in order:
            c, k = int(table.cell[h]), int(table.bin[h])
            wanted = [int(a) if (v, int(a)) in pool else -1 for v, a in enumerate(table.assoc[:, h])]
            new = refine_and_check(
                problem, taken, hyp.centres_base[c], float(hyp.radii[k]), wanted, hyp.bin_semi_up(k), hyp.bin_axis(k)
            )
            if new is not None and boxes_of(problem, new) != banned and (best is None or new.score > best.score):
                best = new
        if best is None:  # the best hypotheses left explain nothing acceptable: the rest score lower still
            break
        out.append(best)
        mine = boxes_of(problem, best)
        pool -= mine
        taken = taken | mine
        live = np.setdiff1d(live, order)
        live = live[table.using(mine, live) == 0]
    return out


def regroup_pass(
    problem: Problem, objects: list[DetectedObject], taken: Taken, hyp: Hypotheses
) -> tuple[list[DetectedObject], Taken]:
    """Each object with the holders of the boxes that the search's other hypotheses on its boxes want, extracted
    again without the object's own association; kept where the boxes are then explained better (see the module).

    The objects a regrouping makes are visited in turn; at most as many regroupings are kept as there were objects.
    Nothing changes where the extraction scored the search's last level lazily (``hyp.child_cell``: a dense scene,
    whose hypothesis table holds the parents only)."""
    cfg = problem.config
    if not objects or hyp.scores[0].size == 0 or hyp.child_cell is not None:
        return objects, taken
    table = _Table.of(problem, hyp)
    current, alive = list(objects), [True] * len(objects)
    all_boxes = {(v, j) for v, vd in enumerate(problem.views) for j in range(len(vd.boxes))}
    kept, i = 0, 0
    while i < len(current) and kept < len(objects):
        holders = {b: g for g, o in enumerate(current) if alive[g] for b in boxes_of(problem, o)}
        group = {i} | _group(problem, hyp, table, current[i], holders) if alive[i] else set()
        if len(group) >= 2:
            old = [current[g] for g in group]
            released = set().union(*(boxes_of(problem, o) for o in old))
            grid_old = np.nan_to_num(_grid_worth_of(problem, table, old), nan=-np.inf)
            pool = released | (all_boxes - taken)
            new = _reextract(problem, hyp, table, pool, released, boxes_of(problem, current[i]), taken - released, grid_old)
            if _worth(new, cfg.accept) > _worth(old, cfg.accept):
                for g in group:
                    alive[g] = False
                taken = (taken - released) | set().union(*(boxes_of(problem, o) for o in new))
                current += new
                alive += [True] * len(new)
                kept += 1
        i += 1
    return [o for o, a in zip(current, alive) if a], taken
