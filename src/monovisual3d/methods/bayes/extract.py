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
    hypotheses. ``users[v]`` indexes the starting associations of view ``v`` by box (the box numbers sorted, and
    the row of each); with ``rescored`` (the rows whose associations changed since) it finds the rows that use a
    box without a pass over all hypotheses.
    """

    total: NDArray[np.float64]
    n_assoc: NDArray[np.int32]
    assoc: NDArray[np.int16]
    active: NDArray[np.bool_]
    eligible: NDArray[np.float64]
    row_best: NDArray[np.float64]
    stale: NDArray[np.bool_]
    users: list[tuple[NDArray[np.int16], NDArray[np.intp]]]
    rescored: NDArray[np.bool_]

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
            [_box_users(a) for a in assoc],
            np.zeros(n, dtype=bool),
        )
        work.update(np.arange(n), min_views)
        return work

    def update(self, rows: NDArray[np.intp], min_views: int) -> None:
        """Recompute ``eligible`` and ``row_best`` in ``rows``."""
        ok = self.active[rows, None] & (self.n_assoc[rows] >= min_views)
        self.eligible[rows] = np.where(ok, self.total[rows], -np.inf)
        self.row_best[rows] = self.eligible[rows].max(axis=1, initial=-np.inf)

    def using(self, v: int, boxes: NDArray[np.intp], rows: NDArray[np.bool_]) -> NDArray[np.intp]:
        """The rows among ``rows`` (N,) bool whose association in view ``v`` holds one of ``boxes``, sorted."""
        js, row_of = self.users[v]
        lo, hi = np.searchsorted(js, boxes, side="left"), np.searchsorted(js, boxes, side="right")
        cand = np.concatenate([row_of[a:b] for a, b in zip(lo, hi)] + [np.flatnonzero(self.rescored)])
        cand = np.unique(cand[rows[cand]])
        return cand[np.isin(self.assoc[v, cand], boxes).any(axis=1)]

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


def _box_users(assoc_v: NDArray[np.int16]) -> tuple[NDArray[np.int16], NDArray[np.intp]]:
    """The boxes that the hypotheses ``assoc_v`` (N, K) of one view associate, sorted, and the row of each use."""
    rows, _ = np.nonzero(assoc_v >= 0)
    js = assoc_v[assoc_v >= 0]
    order = np.argsort(js, kind="stable")
    return js[order], rows[order]


def _candidates(
    problem: Problem, hyp: Hypotheses, work: _Work, taken: Taken, best: float, cache: dict[tuple[int, int], DetectedObject | None]
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
        near = np.linalg.norm(centres - centres[c], axis=1) <= max(2 * hyp.cell, radii[k])
        trial[near] = False
        out.append((cache[key], near))
    return out


def _take(problem: Problem, hyp: Hypotheses, work: _Work, taken: Taken, obj: DetectedObject) -> Taken:
    """Give ``obj`` its boxes: suppress the cells around it and mark stale the hypotheses that used its boxes."""
    new = boxes_of(problem, obj)
    taken = taken | new
    near = np.linalg.norm(hyp.centres_base - obj.position, axis=1) <= max(hyp.cell, 0.5 * float(obj.radius or 0))
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
        work.total[sub], work.n_assoc[sub], work.assoc[:, sub] = t, n, a
        work.stale[sub] = False
        work.rescored[sub] = True
        work.update(sub, problem.config.min_views)


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
    max_iter = sum(len(vd.boxes) for vd in problem.views) * 3 + 10
    for _ in range(max_iter):
        if work.total.size == 0:
            break
        _refresh(problem, hyp, work, taken, lazy)
        best = float(work.row_best.max())
        if not np.isfinite(best) or best < cfg.accept - cfg.prune_slack:
            break
        candidates = _candidates(problem, hyp, work, taken, best, cache)
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
        taken = _take(problem, hyp, work, taken, obj)
    return objects, taken
