"""Greedy explaining-away extraction with look-ahead.

Take the best hypothesis; refine it (:func:`.scoring.refine_and_check`); it
is accepted when at least ``min_views`` views have a box associated to it and
its refined score is at least ``accept`` nats. An accepted object takes its
boxes (they join ``taken``) and the hypotheses that used them are rescored; a
rejected one suppresses the hypotheses around it. Stop when the best
remaining grid score is below ``accept - prune_slack``.

The rescoring is lazy and exact: a hypothesis's score only falls as boxes are taken (the best
remaining box of a view is never better than before, a miss is always there), so its last score
is an upper bound. The hypotheses that used a taken box are marked stale and rescored only when
their bound reaches the band the next step looks at (within ``lookahead_margin`` of the best);
each is scored with the boxes taken by then, exactly as an eager rescoring would leave it, and
most of the ghost hypotheses along the taken boxes' viewing cones are never scored again. The look-ahead refines
up to ``lookahead`` distinct candidates whose grid score is within
``lookahead_margin`` of the best and keeps the best refined one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from ...result import DetectedObject
from .problem import Problem, Taken
from .scoring import boxes_of, refine_and_check, score_hypotheses, score_one
from .search import Hypotheses


@dataclass
class _Work:
    """The extraction's working copy of the scores (private to :func:`extract`).

    ``eligible`` is ``total`` where the row is active and the hypothesis has ``min_views`` associated
    views, else -inf; ``row_best`` its maximum per row. Both are updated only in the rows that change
    (suppressed or rescored), so finding the best hypothesis costs one pass over the rows, not over all
    hypotheses. ``users[v]`` indexes the associations of view ``v`` by box (:class:`_BoxUsers`), so that the rows
    using a box are found without a pass over all hypotheses.
    """

    total: NDArray[np.float64]
    n_assoc: NDArray[np.int32]
    assoc: NDArray[np.int16]
    active: NDArray[np.bool_]
    eligible: NDArray[np.float64]
    row_best: NDArray[np.float64]
    stale: NDArray[np.bool_]
    users: list[_BoxUsers]

    @classmethod
    def start(cls, hyp: Hypotheses, min_views: int) -> _Work:
        return cls.from_scores(*hyp.scores, min_views)

    @classmethod
    def from_scores(
        cls, total: NDArray[np.float64], n_assoc: NDArray[np.int32], assoc: NDArray[np.int16], min_views: int
    ) -> _Work:
        """The working copy of the scores ``total`` (N, K), ``n_assoc`` (N, K) and ``assoc`` (V, N, K), all active."""
        n = len(total)
        work = cls(
            total.copy(),
            n_assoc.copy(),
            assoc.copy(),
            np.ones(n, dtype=bool),
            total.copy(),
            np.zeros(n),
            np.zeros(n, dtype=bool),
            [_BoxUsers.of(a, np.arange(n)) for a in assoc],
        )
        work.update(np.arange(n), min_views)
        return work

    def update(self, rows: NDArray[np.intp], min_views: int) -> None:
        """Recompute ``eligible`` and ``row_best`` in ``rows``."""
        ok = self.active[rows, None] & (self.n_assoc[rows] >= min_views)
        self.eligible[rows] = np.where(ok, self.total[rows], -np.inf)
        self.row_best[rows] = self.eligible[rows].max(axis=1, initial=-np.inf)

    def rescore(
        self,
        rows: NDArray[np.intp],
        total: NDArray[np.float64],
        n_assoc: NDArray[np.int32],
        assoc: NDArray[np.int16],
        min_views: int,
    ) -> None:
        """New scores of the rows ``rows`` (M,): ``total`` and ``n_assoc`` (M, K), ``assoc`` (V, M, K); fresh now."""
        self.total[rows], self.n_assoc[rows], self.assoc[:, rows] = total, n_assoc, assoc
        self.stale[rows] = False
        for users, a in zip(self.users, assoc):
            users.add(a, rows)
        self.update(rows, min_views)

    def using(self, v: int, boxes: NDArray[np.intp], rows: NDArray[np.bool_]) -> NDArray[np.intp]:
        """The rows among ``rows`` (N,) bool whose association in view ``v`` holds one of ``boxes``, sorted."""
        boxes = np.asarray(boxes, dtype=np.intp)
        cand = self.users[v].rows(boxes)
        cand = np.unique(cand[rows[cand]])
        current = self.assoc[v, cand]
        holds = np.zeros(max(int(current.max(initial=-1)), int(np.max(boxes, initial=-1))) + 2, dtype=bool)
        holds[boxes] = True  # holds[-1], the entry of no box, stays False
        return cand[holds[current].any(axis=1)]

    def suppress(self, rows: NDArray[np.bool_]) -> None:
        """Deactivate the cells ``rows`` (N,) bool."""
        self.active[rows] = False
        self.eligible[rows] = -np.inf
        self.row_best[rows] = -np.inf

    def best(self, rows: NDArray[np.bool_]) -> tuple[int, int, float]:
        """The first best eligible hypothesis among ``rows`` (N,) bool, as ``argmax`` over all of them finds it."""
        c = int(np.argmax(np.where(rows, self.row_best, -np.inf))) if len(rows) else 0
        if not len(rows) or not rows[c]:
            return c, 0, -np.inf
        k = int(np.argmax(self.eligible[c]))
        return c, k, float(self.eligible[c, k])


@dataclass(frozen=True)
class _Cells:
    """The hypothesis cells' centres (N, 3), metres, base frame, and a k-d tree of them: the cells near a point are
    found in time growing with their number, not with all cells (an extraction asks once per candidate and object)."""

    centres: NDArray[np.float64]
    tree: cKDTree

    @classmethod
    def of(cls, centres_base: NDArray[np.float64]) -> _Cells:
        return cls(centres_base, cKDTree(centres_base.reshape(-1, 3)))

    def within(self, point: NDArray[np.float64], radius: float) -> NDArray[np.bool_]:
        """Cells (N,) bool whose centre lies within ``radius`` metres of ``point`` (3,): ``norm(c - point) <= radius``
        exactly, tested on the tree's candidates found a hair farther out."""
        out = np.zeros(len(self.centres), dtype=bool)
        if not len(self.centres) or not np.all(np.isfinite(point)):
            return out
        idx = np.asarray(self.tree.query_ball_point(point, radius * (1 + 1e-9) + 1e-12), dtype=np.intp)
        out[idx[np.linalg.norm(self.centres[idx] - point, axis=1) <= radius]] = True
        return out


@dataclass
class _BoxUsers:
    """Which rows associate each box of one view: sorted runs of (box, row) pairs, the rows' associations as they were
    when each run was added (a row rescored since has its new associations in a later run; :meth:`_Work.using` checks
    the current ones). Adding a run merges it with the runs before it while they are not twice as long, so a look-up
    searches a few runs and the merges cost ``O(n log n)`` over all the rescoring.
    """

    runs: list[tuple[NDArray[np.int16], NDArray[np.intp]]]

    @classmethod
    def of(cls, assoc_v: NDArray[np.int16], rows: NDArray[np.intp]) -> _BoxUsers:
        """The index of the associations ``assoc_v`` (M, K) of the rows ``rows`` (M,)."""
        users = cls([])
        users.add(assoc_v, rows)
        return users

    def add(self, assoc_v: NDArray[np.int16], rows: NDArray[np.intp]) -> None:
        """Index the associations ``assoc_v`` (M, K) of the rows ``rows`` (M,)."""
        where, _ = np.nonzero(assoc_v >= 0)
        js = assoc_v[assoc_v >= 0]
        order = np.argsort(js, kind="stable")
        self.runs.append((js[order], rows[where[order]]))
        while len(self.runs) >= 2 and len(self.runs[-2][0]) <= 2 * len(self.runs[-1][0]):
            (j1, r1), (j2, r2) = self.runs.pop(), self.runs.pop()
            js, rs = np.concatenate([j2, j1]), np.concatenate([r2, r1])
            order = np.argsort(js, kind="stable")
            self.runs.append((js[order], rs[order]))

    def rows(self, boxes: NDArray[np.intp]) -> NDArray[np.intp]:
        """Rows indexed with one of ``boxes`` (repeats possible; some no longer use it)."""
        out = []
        keys = np.asarray(boxes).astype(np.int16)  # in the runs' type: a key of another type would convert each run
        for js, rs in self.runs:
            lo, hi = np.searchsorted(js, keys, side="left"), np.searchsorted(js, keys, side="right")
            out += [rs[a:b] for a, b in zip(lo, hi)]
        return np.concatenate(out) if out else np.zeros(0, dtype=np.intp)


def _candidates(
    problem: Problem,
    hyp: Hypotheses,
    work: _Work,
    taken: Taken,
    best: float,
    cache: dict[tuple[int, int], DetectedObject | None],
    cells: _Cells,
) -> list[tuple[DetectedObject | None, NDArray[np.bool_]]]:
    """The look-ahead: refined candidates near the best grid score, each with the cells it stands for."""
    cfg, centres, radii = problem.config, hyp.centres_base, hyp.radii
    floor = cfg.accept - cfg.prune_slack
    trial = work.active.copy()
    out = []
    for _ in range(cfg.lookahead):
        c, k, score = work.best(trial)
        if not np.isfinite(score) or score < max(floor, best - cfg.lookahead_margin):
            break
        key = (c, k)
        if key not in cache:  # a cached result stays valid while its boxes are not taken
            b, u = hyp.bin_semi_up(int(k)), hyp.bin_axis(int(k))
            _, assoc_h = score_one(problem, taken, centres[c], float(radii[k]), hyp.cell, b, u)
            cache[key] = refine_and_check(problem, taken, centres[c], float(radii[k]), assoc_h, b, u)
        near = cells.within(centres[c], max(2 * hyp.cell, radii[k]))
        trial[near] = False
        out.append((cache[key], near))
    return out


def _take(problem: Problem, hyp: Hypotheses, work: _Work, taken: Taken, obj: DetectedObject, cells: _Cells) -> Taken:
    """Give ``obj`` its boxes: suppress the cells around it and mark stale the hypotheses that used its boxes."""
    new = boxes_of(problem, obj)
    taken = taken | new
    near = cells.within(obj.position, max(hyp.cell, 0.5 * float(obj.radius or 0)))
    work.suppress(near)
    live = work.active & ~work.stale  # a stale row is rescored anyway; its associations are old
    for v in {v for v, _ in new}:
        work.stale[work.using(v, np.array([j for vv, j in new if vv == v]), live)] = True
    return taken


def _refresh(problem: Problem, hyp: Hypotheses, work: _Work, taken: Taken, lazy: bool = True) -> None:
    """Rescore the stale rows whose bound lies within ``lookahead_margin`` of the best, until the band is fresh
    (every stale row when not ``lazy``: the eager reference).

    A stale row below the band cannot be the best nor a look-ahead candidate: its true score is at most its bound.
    """
    margin = problem.config.lookahead_margin if lazy else np.inf
    while True:
        best = float(work.row_best.max(initial=-np.inf))
        if not np.isfinite(best):
            return
        sub = np.flatnonzero(work.stale & (work.row_best >= best - margin))
        if len(sub) == 0:
            return
        t, n, a = score_hypotheses(
            problem, taken, hyp.centres_base[sub], hyp.radii, hyp.cell, hyp.mask[sub], hyp.semi_up, hyp.axes
        )
        work.rescore(sub, t, n, a, problem.config.min_views)


def extract(problem: Problem, hyp: Hypotheses, lazy: bool = True) -> tuple[list[DetectedObject], Taken]:
    """Objects found greedily in ``hyp``, and the boxes they took.

    ``lazy=False`` rescores every stale hypothesis after each taken object (the reference the lazy rescoring
    is tested against: the same objects).
    """
    cfg = problem.config
    work = _Work.start(hyp, cfg.min_views)
    objects: list[DetectedObject] = []
    taken: Taken = frozenset()
    cache: dict[tuple[int, int], DetectedObject | None] = {}
    cells = _Cells.of(hyp.centres_base)
    max_iter = sum(len(vd.boxes) for vd in problem.views) * 3 + 10
    for _ in range(max_iter):
        if work.total.size == 0:
            break
        _refresh(problem, hyp, work, taken, lazy)
        best = float(work.row_best.max())
        if not np.isfinite(best) or best < cfg.accept - cfg.prune_slack:
            break
        candidates = _candidates(problem, hyp, work, taken, best, cache, cells)
        for cand, near in candidates:
            if cand is None:
                work.suppress(near)
        accepted = [cand for cand, _ in candidates if cand is not None]
        if not accepted:
            continue
        obj = max(accepted, key=lambda o: o.score)
        objects.append(obj)
        mine = boxes_of(problem, obj)
        cache = {key: o for key, o in cache.items() if o is not None and o is not obj and not mine & boxes_of(problem, o)}
        taken = _take(problem, hyp, work, taken, obj, cells)
    return objects, taken
