"""Objects whose boxes belong to several fruit: regrouped with their neighbours when that explains the boxes better.

Three rays through boxes of three different fruit can meet in front of or behind the plant, and the object there
explains them like a fruit seen three times: the greedy extraction takes it first when it scores best. Each fruit that
gave it a box is then left with two views and either lost or paired with another fruit's box; no steal or swap move
undoes that, as each leaves a holder with one box (why: docs/decisions/bayes-association.md#regroup).

:func:`regroup_pass` takes each object in turn and the best hypotheses of the search that use one of its boxes with
another association. The object and the holders of the boxes those hypotheses want give up their boxes; the boxes so
released, with the free ones, are extracted again as the extraction does, twice: as if the object's boxes belonged to
different objects (no new object holds two of them: a crossing), and as if one of them were wrong (no new object holds
exactly them: a fruit that took a neighbour's box). The better set of new objects replaces the old ones when its
summed score above ``accept`` is higher (each object pays ``accept``, as in the extraction, so that splitting evidence
into more objects is not free).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .hypotheses import BoxUsers, best_accepted, same_place_m, still_valid
from .problem import Problem
from .scoring import associations_list, boxes_of, held_boxes, refine_and_check
from .state import Found, Hypotheses, State, Taken

#: Hypotheses on an object's boxes tried per object (the best, at distinct places) to find the objects to regroup with
#: it: one per box of a three-view object, the commonest crossing (each of its boxes has one rightful holder).
CANDIDATES_PER_OBJECT = 3

Box = tuple[int, int]


@dataclass(frozen=True)
class _Table:
    """The search's hypotheses that could be objects (enough views, a score near ``accept``), flattened, with the
    hypotheses using each box, so that each step looks only at the hypotheses on the boxes it touches.

    ``score`` (n,) float64 nats; ``assoc`` (V, n) int16, box per view (-1: none); ``cell`` and ``bin`` (n,) their
    cell and radius bin in ``hyp``; ``by_box[v]`` the hypotheses using each box of view ``v`` (:class:`.extract.BoxUsers`).
    """

    score: NDArray[np.float64]
    assoc: NDArray[np.int16]
    cell: NDArray[np.intp]
    bin: NDArray[np.intp]
    by_box: list[BoxUsers]

    @classmethod
    def of(cls, problem: Problem, hyp: Hypotheses) -> _Table:
        cfg = problem.config
        total, n_assoc, assoc = hyp.scores
        flat = np.flatnonzero((n_assoc >= cfg.min_views) & (total >= cfg.accept - cfg.tuning.prune_slack))
        cell, k = np.divmod(flat, total.shape[1])
        assoc = assoc.reshape(len(assoc), -1)[:, flat]
        return cls.build(total.reshape(-1)[flat], assoc, cell, k)

    @classmethod
    def build(
        cls, score: NDArray[np.float64], assoc: NDArray[np.int16], cell: NDArray[np.intp], bin_: NDArray[np.intp]
    ) -> _Table:
        """The table of hypotheses ``score`` (n,) nats, ``assoc`` (V, n), ``cell`` and ``bin_`` (n,)."""
        rows = np.arange(len(score))
        return cls(score, assoc, cell, bin_, [BoxUsers.of(a[:, None], rows) for a in assoc])

    def users(self, boxes: set[Box]) -> NDArray[np.intp]:
        """The hypotheses (indices, sorted) that use at least one of ``boxes``."""
        parts = [self.by_box[v].hypotheses(np.array([j])) for v, j in boxes]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=np.intp)

    def n_boxes(self, among: NDArray[np.intp]) -> NDArray[np.int64]:
        """How many boxes each hypothesis of ``among`` uses, shape (len(among),)."""
        return np.count_nonzero(self.assoc[:, among] >= 0, axis=0)

    def using(self, boxes: set[Box], among: NDArray[np.intp]) -> NDArray[np.int64]:
        """How many of ``boxes`` each hypothesis of ``among`` uses, shape (len(among),)."""
        count = np.zeros(len(among), dtype=np.int64)
        for v in range(len(self.assoc)):
            js = [j for u, j in boxes if u == v]
            if js:
                count += np.isin(self.assoc[v, among], js)
        return count


def _grid_worth_of(problem: Problem, table: _Table, objects: list[Found]) -> float:
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
    refinement: each step takes the best and drops those sharing a box with it. Optimistic: a hypothesis's grid
    score may count boxes that other objects hold."""
    worth = 0.0
    while len(live):
        h = live[np.argmax(table.score[live])]
        if table.score[h] < accept:
            break
        worth += float(table.score[h]) - accept
        live = live[~np.any((table.assoc[:, live] == table.assoc[:, h : h + 1]) & (table.assoc[:, h : h + 1] >= 0), axis=0)]
    return worth


def _worth(objects: list[Found], accept: float) -> float:
    """The summed score above ``accept`` of ``objects`` (nats)."""
    return float(sum(o.score - accept for o in objects))


def _group(problem: Problem, hyp: Hypotheses, table: _Table, obj: Found, holders: dict[Box, int]) -> set[int]:
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
        near = np.linalg.norm(centres - centres[best], axis=1) <= same_place_m(hyp.cell, float(hyp.radii[table.bin[h]]))
        cand, centres = cand[~near], centres[~near]
    return group


@dataclass
class _Pool:
    """The boxes a re-extraction may give out (``boxes``; the rest are ``taken``) and the regrouped object's boxes
    ``own``: with ``split``, no new object may hold two of them (they are taken to be different objects'); without,
    no new object may hold exactly them (the object is taken to hold a wrong box)."""

    boxes: set[Box]
    taken: Taken
    own: set[Box]
    split: bool

    def allows(self, obj: Found | None, problem: Problem) -> bool:
        if obj is None:
            return False
        mine = boxes_of(problem, obj)
        return len(mine & self.own) <= 1 if self.split else mine != self.own

    def take(self, boxes: set[Box]) -> None:
        self.boxes -= boxes
        self.taken = self.taken | boxes


def _refined(problem: Problem, hyp: Hypotheses, table: _Table, h: int, pool: _Pool) -> Found | None:
    """Hypothesis ``h`` refined on the boxes of ``pool`` it wants (re-associating among those not taken)."""
    c, k = int(table.cell[h]), int(table.bin[h])
    wanted = [int(a) if (v, int(a)) in pool.boxes else -1 for v, a in enumerate(table.assoc[:, h])]
    new = refine_and_check(
        problem, pool.taken, hyp.centres_base[c], float(hyp.radii[k]), wanted, hyp.bin_semi_up(k), hyp.bin_axis(k)
    )
    return new if pool.allows(new, problem) else None


def _reextract(
    problem: Problem, hyp: Hypotheses, table: _Table, pool: _Pool, released: set[Box], old_grid_worth: float
) -> list[Found] | None:
    """Objects extracted greedily from ``pool``, each from a hypothesis using a ``released`` box (those on free boxes
    alone the extraction refused already), as the extraction does: per step the best hypotheses at up to
    ``lookahead`` distinct places within ``lookahead_margin`` of the best are refined and the best accepted one is
    taken; the places of those that fail are dropped.

    None (not tried) where the same greedy extraction on the grid's scores falls more than ``lookahead_margin`` below
    ``old_grid_worth``, the objects' own grid worth (:func:`_grid_worth_of`): the refinement would not close that gap."""
    cfg = problem.config
    live = table.users(released)
    live = live[table.using(pool.boxes, live) >= cfg.min_views]
    own = table.using(pool.own, live)
    live = live[own <= 1] if pool.split else live[(own < len(pool.own)) | (table.n_boxes(live) != len(pool.own))]
    if _grid_worth_again(table, live, cfg.accept) < old_grid_worth - cfg.tuning.lookahead_margin:
        return None
    out: list[Found] = []
    cache: dict[int, Found | None] = {}
    while len(live):
        trial, tried, floor = live, [], table.score[live].max() - cfg.tuning.lookahead_margin
        for _ in range(cfg.tuning.lookahead):
            h = int(trial[np.argmax(table.score[trial])]) if len(trial) else -1
            if h < 0 or table.score[h] < floor:
                break
            if h not in cache:
                cache[h] = _refined(problem, hyp, table, h, pool)
            radius = same_place_m(hyp.cell, float(hyp.radii[table.bin[h]]))
            near = np.linalg.norm(hyp.centres_base[table.cell[trial]] - hyp.centres_base[table.cell[h]], axis=1) <= radius
            tried.append((cache[h], trial[near]))
            trial = trial[~near]
        for obj, place in tried:
            if obj is None:
                live = np.setdiff1d(live, place)
        best = best_accepted([obj for obj, _ in tried])
        if best is None:
            continue
        out.append(best)
        pool.take(boxes_of(problem, best))
        cache = still_valid(problem, cache, best)
        live = live[table.using(pool.boxes, live) >= cfg.min_views]
    return out


def regroup_pass(problem: Problem, objects: list[Found], hyp: Hypotheses) -> list[Found]:
    """Each object with the holders of the boxes that the search's other hypotheses on its boxes want, extracted
    again as if the object's boxes belonged to different objects or one of them were wrong; kept where the boxes
    are then explained better (see the module).

    The objects a regrouping makes are visited in turn; at most as many regroupings are kept as there were objects.
    Nothing changes where the extraction scored the search's last level lazily (``hyp.child_cell``: a dense scene,
    whose hypothesis table holds the parents only)."""
    cfg = problem.config
    if not objects or hyp.scores[0].size == 0 or hyp.child_cell is not None:
        return objects
    taken = held_boxes(problem, objects)
    table = _Table.of(problem, hyp)
    current, alive = list(objects), [True] * len(objects)
    holders = {b: g for g, o in enumerate(current) for b in boxes_of(problem, o)}
    free = {(v, j) for v, vd in enumerate(problem.views) for j in range(len(vd.boxes))} - taken
    kept, i = 0, 0
    while i < len(current) and kept < len(objects):
        group = {i} | _group(problem, hyp, table, current[i], holders) if alive[i] else set()
        if len(group) >= 2:
            old = [current[g] for g in group]
            released = set().union(*(boxes_of(problem, o) for o in old))
            grid_old = np.nan_to_num(_grid_worth_of(problem, table, old), nan=-np.inf)
            best_worth, new, pool = _worth(old, cfg.accept), [], None
            for split in (True, False):  # the object's boxes are different objects', or one of them is wrong
                trial = _Pool(released | free, taken - released, boxes_of(problem, current[i]), split)
                found = _reextract(problem, hyp, table, trial, released, grid_old) or []
                if found and _worth(found, cfg.accept) > best_worth:
                    best_worth, new, pool = _worth(found, cfg.accept), found, trial
            if pool is not None:
                for g in group:
                    alive[g] = False
                for b in released:
                    holders.pop(b)
                for o in new:
                    holders.update({b: len(current) for b in boxes_of(problem, o)})
                    current.append(o)
                    alive.append(True)
                taken, free = pool.taken, pool.boxes
                kept += 1
        i += 1
    return [o for o, a in zip(current, alive) if a]


def run(problem: Problem, state: State) -> State:
    """The pass: :func:`regroup_pass` on the state's objects and the search's hypotheses."""
    assert state.hypotheses is not None
    return state.with_objects(regroup_pass(problem, list(state.objects), state.hypotheses))
