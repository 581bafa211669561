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

When the search leaves its last level to the extraction (``Hypotheses.child_cell``: a dense scene), the rows start
as the cells of the level above, and a cell is replaced by its 8 children, scored with the boxes left, when it reaches
the band; a ghost crossing whose boxes are taken first sinks below the band at its own, cheaper rescoring and is never
split. A cell's score is blurred over its size, and its best child may score a few nats above it: a child could thus
miss the look-ahead that the eager order would give it; none has changed an object
(why: docs/decisions/bayes-search.md#lazy-children).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...grid import child_rows
from .hypotheses import BoxUsers, best_accepted, same_place_m, score_children, still_valid
from .problem import Problem
from .scoring import boxes_of, refine_and_check, score_hypotheses, score_one
from .state import Found, Hypotheses, State, Taken


def _extended(
    buffers: dict[str, NDArray[Any]], name: str, current: NDArray[Any], new: NDArray[Any], axis: int = 0
) -> NDArray[Any]:
    """``current`` with ``new`` appended along ``axis``: a view of ``buffers[name]``, which doubles when full, so that
    growing an array row by row costs time in proportion to its final length."""
    n, m = current.shape[axis], new.shape[axis]
    buf = buffers.get(name)
    head = [slice(None)] * current.ndim
    if buf is None or buf.shape[axis] < n + m:
        shape = list(current.shape)
        shape[axis] = 2 * (n + m)
        buf = np.empty(shape, dtype=current.dtype)
        head[axis] = slice(0, n)
        buf[tuple(head)] = current
        buffers[name] = buf
    head[axis] = slice(n, n + m)
    buf[tuple(head)] = new
    head[axis] = slice(0, n + m)
    return buf[tuple(head)]


@dataclass
class _Work:
    """The extraction's working copy of the scores (private to :func:`extract`).

    ``eligible`` is ``total`` where the row is active and the hypothesis has ``min_views`` associated
    views, else -inf; ``row_best`` its maximum per row. Both are updated only in the rows that change
    (suppressed or rescored), so finding the best hypothesis costs one pass over the rows, not over all
    hypotheses. ``users[v]`` indexes the associations of view ``v`` by box (:class:`BoxUsers`), so that the rows
    using a box are found without a pass over all hypotheses.
    """

    total: NDArray[np.float64]
    n_assoc: NDArray[np.int32]
    assoc: NDArray[np.int16]
    active: NDArray[np.bool_]
    eligible: NDArray[np.float64]
    row_best: NDArray[np.float64]
    stale: NDArray[np.bool_]
    users: list[BoxUsers]
    pending: NDArray[np.bool_]
    buffers: dict[str, NDArray[Any]] = field(default_factory=dict)

    @classmethod
    def from_scores(
        cls,
        total: NDArray[np.float64],
        n_assoc: NDArray[np.int32],
        assoc: NDArray[np.int16],
        min_views: int,
        pending: NDArray[np.bool_] | None = None,
    ) -> _Work:
        """The working copy of the scores ``total`` (N, K), ``n_assoc`` (N, K) and ``assoc`` (V, N, K), all active;
        ``pending`` (N,) bool: the rows that are cells still to be split (none by default)."""
        n = len(total)
        work = cls(
            total.copy(),
            n_assoc.copy(),
            assoc.copy(),
            np.ones(n, dtype=bool),
            total.copy(),
            np.zeros(n),
            np.zeros(n, dtype=bool),
            [BoxUsers.of(a, np.arange(n), _holders(n_assoc)) for a in assoc],
            np.zeros(n, dtype=bool) if pending is None else pending.copy(),
        )
        work.update(np.arange(n), min_views)
        return work

    def append(
        self, total: NDArray[np.float64], n_assoc: NDArray[np.int32], assoc: NDArray[np.int16], min_views: int
    ) -> NDArray[np.intp]:
        """Add fresh active rows with the scores ``total``, ``n_assoc`` (M, K) and ``assoc`` (V, M, K); their indices."""
        n, m = len(self.total), len(total)
        rows = np.arange(n, n + m)
        new = {"total": total, "n_assoc": n_assoc, "eligible": total, "row_best": np.zeros(m)}
        new |= {"active": np.ones(m, dtype=bool), "stale": np.zeros(m, dtype=bool), "pending": np.zeros(m, dtype=bool)}
        for name, value in new.items():
            setattr(self, name, _extended(self.buffers, name, getattr(self, name), value))
        self.assoc = _extended(self.buffers, "assoc", self.assoc, assoc, axis=1)
        held = _holders(n_assoc)
        for users, a in zip(self.users, assoc):
            users.add(a, rows, held)
        self.update(rows, min_views)
        return rows

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
        held = _holders(n_assoc)
        for users, a in zip(self.users, assoc):
            users.add(a, rows, held)
        self.update(rows, min_views)

    def using(self, v: int, boxes: NDArray[np.intp], rows: NDArray[np.bool_]) -> NDArray[np.intp]:
        """The rows among ``rows`` (N,) bool whose association in view ``v`` holds one of ``boxes``, sorted."""
        boxes = np.asarray(boxes, dtype=np.intp)
        cand = self.users[v].hypotheses(boxes)
        row, k = np.divmod(cand, self.assoc.shape[2])
        keep = rows[row]
        row, k = row[keep], k[keep]
        current = self.assoc[v, row, k]  # every current association was indexed when it was scored
        holds = np.zeros(max(int(current.max(initial=-1)), int(np.max(boxes, initial=-1))) + 2, dtype=bool)
        holds[boxes] = True  # holds[-1], the entry of no box, stays False
        return np.unique(row[holds[current]])

    def suppress(self, rows: NDArray[np.bool_] | NDArray[np.intp]) -> None:
        """Deactivate the cells ``rows`` ((N,) bool, or indices)."""
        self.active[rows] = False
        self.eligible[rows] = -np.inf
        self.row_best[rows] = -np.inf

    def best(self, rows: NDArray[np.bool_] | None = None) -> tuple[int, int, float]:
        """The first best eligible hypothesis among ``rows`` (N,) bool (None: every row), as ``argmax`` over all of them
        finds it."""
        if rows is None:  # an inactive row's best is -inf already
            c = int(np.argmax(self.row_best)) if len(self.row_best) else 0
            if not len(self.row_best) or self.row_best[c] == -np.inf:
                return c, 0, -np.inf
        else:
            c = int(np.argmax(np.where(rows, self.row_best, -np.inf))) if len(rows) else 0
            if not len(rows) or not rows[c]:
                return c, 0, -np.inf
        k = int(np.argmax(self.eligible[c]))
        return c, k, float(self.eligible[c, k])


@dataclass(frozen=True)
class _Cells:
    """The hypothesis cells' centres (N, 3), metres, base frame, sorted along their longest extent: the cells near a
    point are tested within a slab of that axis, not among all cells (an extraction asks once per candidate and
    object; on a plant row the slab holds a few percent of the cells), and within the slab first along the second
    longest extent. Plain numpy: a k-d tree would import ``scipy.spatial`` (0.2-0.4 s of every command's start, issue
    56)."""

    centres: NDArray[np.float64]
    axis: int
    keys: NDArray[np.float64]
    order: NDArray[np.intp]
    sorted_centres: NDArray[np.float64]
    second: int

    @classmethod
    def of(cls, centres_base: NDArray[np.float64]) -> _Cells:
        centres = centres_base.reshape(-1, 3)
        extent = np.ptp(centres, axis=0) if len(centres) else np.zeros(3)
        axis = int(np.argmax(extent))
        second = int(np.argmax(np.where(np.arange(3) == axis, -np.inf, extent)))
        order = np.argsort(centres[:, axis], kind="stable")
        sorted_centres = np.ascontiguousarray(centres[order])
        return cls(centres, axis, sorted_centres[:, axis].copy(), order, sorted_centres, second)

    def within(self, point: NDArray[np.float64], radius: float) -> NDArray[np.intp]:
        """Indices of the cells whose centre lies within ``radius`` metres of ``point`` (3,): ``norm(c - point) <=
        radius`` exactly, tested on the candidates of the slab ``|c[axis] - point[axis]|`` a hair over ``radius`` (and
        as much along the second axis: a coordinate exceeds the norm by at most rounding); in the slab's order, each
        once. Indices, not an (N,) mask: an extraction asks hundreds of times, and a mask of every cell would cost
        each ask in proportion to all the cells."""
        if not len(self.centres) or not np.all(np.isfinite(point)):
            return np.zeros(0, dtype=np.intp)
        reach = radius * (1 + 1e-9) + 1e-12
        lo = int(np.searchsorted(self.keys, point[self.axis] - reach, side="left"))
        hi = int(np.searchsorted(self.keys, point[self.axis] + reach, side="right"))
        slab = self.sorted_centres[lo:hi]
        cand = np.flatnonzero(np.abs(slab[:, self.second] - point[self.second]) <= reach)
        cand = cand[np.linalg.norm(slab[cand] - point, axis=1) <= radius]
        return self.order[lo + cand]


def _holders(n_assoc: NDArray[np.int32]) -> NDArray[np.intp]:
    """Flat indices into ``n_assoc`` (M, K) of the hypotheses with a box in some view: most hold none (a dense
    scene's bins ruled out, or explained away), so the box index looks only at these."""
    return np.flatnonzero(n_assoc > 0)


@dataclass
class _Rows:
    """The rows the extraction draws from, and the last-level cells they stand for.

    Without ``Hypotheses.child_cell`` the rows are the search's cells, one last-level cell each. With it they start as
    the search's cells one level above (the first ``n_parents`` rows, scored at ``parent_cell``), and a cell's 8 children (last-level
    cells ``8 i`` to ``8 i + 7`` of cell ``i``) become rows only when it nears the best (:func:`_split`); most cells of
    ghost crossings never do, their boxes taken first. A last-level cell suppressed (``dead``) before it is a row never
    becomes one.

    Attributes
    ----------
    hyp : Hypotheses, the search's result (its bins, and its cells' every-box scores)
    centres : ndarray, shape (M, 3), metres, base frame: each row's centre
    mask : ndarray, shape (M, K), bool: the bins each row scores
    n_parents : int, rows that are cells of the level above the last (the first ones; 0 without ``child_cell``)
    fine_centres : ndarray, shape (F, 3), metres, base frame: the last-level cells
    fine_mask : ndarray, shape (F, K), bool: the bins each last-level cell would score
    row_of : ndarray, shape (F,), intp: each last-level cell's row, -1 while it has none
    dead : ndarray, shape (F,), bool: last-level cells suppressed
    cell, parent_cell : float, metres: the last level's cell size and the one above
    """

    hyp: Hypotheses
    centres: NDArray[np.float64]
    mask: NDArray[np.bool_]
    n_parents: int
    fine_centres: NDArray[np.float64]
    fine_mask: NDArray[np.bool_]
    row_of: NDArray[np.intp]
    dead: NDArray[np.bool_]
    cell: float
    parent_cell: float
    buffers: dict[str, NDArray[Any]] = field(default_factory=dict)

    @classmethod
    def of(cls, hyp: Hypotheses) -> _Rows:
        n = len(hyp.centres_base)
        if hyp.child_cell is None or hyp.children_base is None or hyp.children_mask is None:
            n_parents, fine, fine_mask, row_of, cell = 0, hyp.centres_base, hyp.mask, np.arange(n), hyp.cell
        else:
            fine, fine_mask, cell = hyp.children_base, hyp.children_mask, hyp.child_cell
            n_parents, row_of = n, np.full(len(fine), -1, dtype=np.intp)
        dead = np.zeros(len(fine), dtype=bool)
        return cls(hyp, hyp.centres_base, hyp.mask, n_parents, fine, fine_mask, row_of, dead, cell, hyp.cell)

    def cell_of(self, rows: NDArray[np.intp]) -> NDArray[np.float64]:
        """Cell size (metres) each of ``rows`` stands for."""
        return np.where(rows < self.n_parents, self.parent_cell, self.cell)

    def add(self, fine: NDArray[np.intp], rows: NDArray[np.intp], mask: NDArray[np.bool_]) -> None:
        """The last-level cells ``fine`` became the rows ``rows`` (M,), scoring the bins ``mask`` (M, K)."""
        self.centres = _extended(self.buffers, "centres", self.centres, self.fine_centres[fine])
        self.mask = _extended(self.buffers, "mask", self.mask, mask)
        self.row_of[fine] = rows


def _kill(rows: _Rows, work: _Work, fine: NDArray[np.intp]) -> None:
    """Suppress the last-level cells ``fine`` (indices): their rows now, and for good those that are not rows yet."""
    rows.dead[fine] = True
    r = rows.row_of[fine]
    work.suppress(r[r >= 0])


def _candidates(
    problem: Problem,
    rows: _Rows,
    work: _Work,
    taken: Taken,
    best: float,
    cache: dict[tuple[int, int], Found | None],
    cells: _Cells,
) -> list[tuple[Found | None, NDArray[np.intp]]]:
    """The look-ahead: refined candidates near the best grid score, each with the last-level cells (indices) it stands
    for."""
    cfg, hyp = problem.config, rows.hyp
    floor = cfg.accept - cfg.tuning.prune_slack
    out = []
    # a candidate's rows are left out of the next one's choice by setting their best to -inf, restored at the end
    # (not a copy of every row's flag per step: the rows grow with the scene, the candidates' rows do not)
    hidden: list[tuple[NDArray[np.intp], NDArray[np.float64]]] = []
    try:
        for _ in range(cfg.tuning.lookahead):
            c, k, score = work.best()
            if not np.isfinite(score) or score < max(floor, best - cfg.tuning.lookahead_margin):
                break
            key = (c, k)
            centre, radius = rows.centres[c], float(hyp.radii[k])
            if key not in cache:  # a cached result stays valid while its boxes are not taken
                b, u = hyp.bin_semi_up(int(k)), hyp.bin_axis(int(k))
                _, assoc_h = score_one(problem, taken, centre, radius, rows.cell, b, u)
                cache[key] = refine_and_check(problem, taken, centre, radius, assoc_h, b, u)
            near = cells.within(centre, same_place_m(rows.cell, radius))
            r = rows.row_of[near]
            r = r[r >= 0]
            hidden.append((r, work.row_best[r]))
            work.row_best[r] = -np.inf
            out.append((cache[key], near))
    finally:
        for r, saved in reversed(hidden):  # last hidden first: a row hidden twice gets its value from before both
            work.row_best[r] = saved
    return out


def _take(problem: Problem, rows: _Rows, work: _Work, taken: Taken, obj: Found, cells: _Cells) -> Taken:
    """Give ``obj`` its boxes: suppress the cells around it and mark stale the hypotheses that used its boxes."""
    new = boxes_of(problem, obj)
    taken = taken | new
    _kill(rows, work, cells.within(obj.position, max(rows.cell, 0.5 * float(obj.radius or 0))))
    live = work.active & ~work.stale  # a stale row is rescored anyway; its associations are old
    for v in {v for v, _ in new}:
        work.stale[work.using(v, np.array([j for vv, j in new if vv == v]), live)] = True
    return taken


def _rescore(problem: Problem, rows: _Rows, work: _Work, taken: Taken, sub: NDArray[np.intp]) -> None:
    """Score the rows ``sub`` again with the boxes not in ``taken``, each at its own cell size."""
    hyp, cells = rows.hyp, rows.cell_of(sub)
    for cell in np.unique(cells):
        part = sub[cells == cell]
        t, n, a = score_hypotheses(
            problem, taken, rows.centres[part], hyp.radii, float(cell), rows.mask[part], hyp.semi_up, hyp.axes
        )
        work.rescore(part, t, n, a, problem.config.min_views)


def _split(problem: Problem, rows: _Rows, work: _Work, taken: Taken, parents: NDArray[np.intp]) -> None:
    """Replace the cells ``parents`` (rows) by their children not suppressed, scored with the boxes not in ``taken``
    (:func:`.search.score_children`; the explaining away is the extraction's own)."""
    work.pending[parents] = False
    work.suppress(parents)
    kids = child_rows(parents)  # parent rows are the search's cells, in its order
    kids, (t, n, a), keep = score_children(problem, rows.hyp, kids[~rows.dead[kids]], taken)
    rows.add(kids, work.append(t, n, a, problem.config.min_views), keep)


def _refresh(problem: Problem, rows: _Rows, work: _Work, taken: Taken, lazy: bool = True) -> None:
    """Rescore the stale rows whose bound lies within ``lookahead_margin`` of the best, and split the cells there,
    until the band holds fresh last-level rows only (every stale row and cell when not ``lazy``: the eager reference).

    A stale row below the band cannot be the best nor a look-ahead candidate: its true score is at most its bound.
    A stale cell is rescored before it is split: most drop out of the band then (their boxes are taken). A cell waiting
    to be split bounds its children only approximately (see the module docstring).
    """
    margin = problem.config.tuning.lookahead_margin if lazy else np.inf
    while True:
        best = float(work.row_best.max(initial=-np.inf))
        if not np.isfinite(best):
            return
        band = work.row_best >= best - margin
        sub = np.flatnonzero(work.stale & band)
        if len(sub):
            _rescore(problem, rows, work, taken, sub)
            continue
        parents = np.flatnonzero(work.pending & band)
        if not len(parents):
            return
        _split(problem, rows, work, taken, parents)


def extract(problem: Problem, hyp: Hypotheses, lazy: bool = True) -> tuple[list[Found], Taken]:
    """Objects found greedily in ``hyp``, and the boxes they took.

    ``lazy=False`` rescores every stale hypothesis after each taken object (the reference the lazy rescoring is
    tested against: the same objects) and splits every cell at once (unlike the search's eager last level, without
    its explaining away).
    """
    cfg = problem.config
    rows = _Rows.of(hyp)
    work = _Work.from_scores(*hyp.scores, cfg.min_views, pending=np.arange(len(rows.centres)) < rows.n_parents)
    objects: list[Found] = []
    taken: Taken = frozenset()
    cache: dict[tuple[int, int], Found | None] = {}
    cells = _Cells.of(rows.fine_centres)
    max_iter = sum(len(vd.boxes) for vd in problem.views) * 3 + 10
    for _ in range(max_iter):
        if work.total.size == 0:
            break
        _refresh(problem, rows, work, taken, lazy)
        best = float(work.row_best.max(initial=-np.inf))
        if not np.isfinite(best) or best < cfg.accept - cfg.tuning.prune_slack:
            break
        candidates = _candidates(problem, rows, work, taken, best, cache, cells)
        for cand, near in candidates:
            if cand is None:
                _kill(rows, work, near)
        obj = best_accepted([cand for cand, _ in candidates])
        if obj is None:
            continue
        objects.append(obj)
        cache = still_valid(problem, cache, obj)
        taken = _take(problem, rows, work, taken, obj, cells)
    return objects, taken


def run(problem: Problem, state: State) -> State:
    """The pass: the objects :func:`extract` takes from the search's hypotheses."""
    assert state.hypotheses is not None
    return state.with_objects(extract(problem, state.hypotheses)[0])
