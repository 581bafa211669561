"""What the passes do with the search's hypotheses: score a cell's children, the last level, the boxes' users.

The search (:mod:`.search`) leaves a :class:`~.state.Hypotheses`; the extraction, the steal and the regroup passes read
it: :func:`score_children` scores the last-level cells under a cell with the boxes left, :func:`last_level` scores
the whole last level where the extraction split it lazily, :class:`BoxUsers` finds the hypotheses that use a box,
:func:`same_place_m` says which hypotheses stand for one object, and :func:`best_accepted` / :func:`still_valid` are
the extraction's rule for taking one refined candidate.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...grid import cell_half_diagonal, child_rows, cone_counts
from ._kernels import cone_counts_fused
from .problem import Problem
from .scoring import boxes_of, score_hypotheses
from .state import Found, Hypotheses, Scores, Taken


def same_place_m(cell: float, radius: float) -> float:
    """Metres within which hypotheses stand for the same object as one at that place: two cells of the search's
    ``cell`` (metres; its resolution, below which the grid cannot tell places apart) or the object's ``radius``
    (metres), whichever is larger. The extraction's look-ahead, the steal and the regroup passes try one candidate per
    such place."""
    return max(2 * cell, radius)


def cone_counts_within(problem: Problem, centres_base: NDArray[np.float64], half_diagonal: float) -> NDArray[np.int32]:
    if problem.config.backend == "numba":
        views = problem.views
        return cone_counts_fused(
            problem.camera, [vd.T_optical_base for vd in views], [vd.boxes for vd in views], centres_base, half_diagonal
        )
    return cone_counts(problem.camera, [vd.view for vd in problem.views], centres_base, half_diagonal)


def _plausible_shapes(
    total: NDArray[np.float64], radii: NDArray[np.float64], semi_up: NDArray[np.float64], slack: float
) -> NDArray[np.bool_]:
    """Which bins of each cell stay in the search: every sphere bin, and the elongated bins (upright or lying spheroids)
    scoring at least the cell's best sphere bin minus ``slack`` nats, shape (N, K) (the search passes
    ``elongation_slack + elongation_cost``: the box evidence is compared, not the prior).

    A round object's box is explained better by a sphere at every level, so its elongated bins stop being
    refined early (they would only cost time); a tall object's are better than any sphere and stay.
    """
    sphere = semi_up == radii
    if sphere.all() or not sphere.any():
        return np.ones(total.shape, dtype=bool)
    best_sphere = total[:, sphere].max(axis=1, keepdims=True)
    return sphere[None, :] | (total >= best_sphere - slack)


def level_mask(problem: Problem, scores: Scores, dominated: NDArray[np.bool_] | None) -> NDArray[np.bool_]:
    """The hypotheses a level keeps, shape (N, K): at least ``accept - prune_slack`` (scores only fall as boxes are
    taken, so one below it never matters again), ``min_views`` views, a plausible shape (:func:`_plausible_shapes`)
    and, with ``dominated`` (N, K), not explained away (:func:`box_dominated`)."""
    cfg = problem.config
    radii, semi_up = cfg.hypothesis_bins
    total, n_assoc, _ = scores
    keep = (
        (total >= cfg.accept - cfg.tuning.prune_slack)
        & (n_assoc >= cfg.min_views)
        & _plausible_shapes(total, radii, semi_up, cfg.tuning.elongation_slack + cfg.tuning.elongation_cost)
    )
    return keep if dominated is None else keep & ~dominated


def cone_counts_at(problem: Problem, centres_base: NDArray[np.float64], cell: float) -> NDArray[np.int32]:
    """Views whose widened viewing cones hold each cell of size ``cell`` (metres) centred at ``centres_base`` (N, 3)."""
    return cone_counts_within(problem, centres_base, cell_half_diagonal(cell))


def score_children(
    problem: Problem, hyp: Hypotheses, kids: NDArray[np.intp], taken: Taken
) -> tuple[NDArray[np.intp], Scores, NDArray[np.bool_]]:
    """The last-level cells ``kids`` (indices into ``hyp.children_base``) in at least ``min_views`` viewing cones,
    scored with the boxes not in ``taken``, that keep a bin (:func:`level_mask` without the explaining away): their
    indices (M,), scores and kept bins (M, K)."""
    assert hyp.child_cell is not None and hyp.children_base is not None and hyp.children_mask is not None
    kids = kids[cone_counts_at(problem, hyp.children_base[kids], hyp.child_cell) >= problem.config.min_views]
    centres, mask = hyp.children_base[kids], hyp.children_mask[kids]
    t, n, a = score_hypotheses(problem, taken, centres, hyp.radii, hyp.child_cell, mask, hyp.semi_up, hyp.axes)
    keep = level_mask(problem, (t, n, a), None)
    good = keep.any(axis=1)
    return kids[good], (t[good], n[good], a[:, good]), keep[good]


def last_level(problem: Problem, hyp: Hypotheses, cells: NDArray[np.bool_]) -> Hypotheses:
    """The last level in the children of ``hyp``'s cells ``cells`` (N,) bool, scored with every box: what the search
    keeps there, without its explaining away, as a last-level :class:`Hypotheses` (``hyp`` itself when it is the last
    level)."""
    if hyp.child_cell is None:
        return hyp
    kids, scores, keep = score_children(problem, hyp, child_rows(np.flatnonzero(cells)), frozenset())
    assert hyp.children_base is not None
    last = Hypotheses(hyp.children_base[kids], hyp.radii, hyp.child_cell, scores, keep, hyp.n_scored, hyp.start_cell, hyp.capped)
    return replace(last, semi_up=hyp.semi_up, axes=hyp.axes)


@dataclass
class BoxUsers:
    """Which hypotheses associate each box of one view: sorted runs of (box, hypothesis) pairs, a hypothesis as its
    flat index ``row * K + bin``, and its association as it was when the run was added (a row rescored since has its
    new associations in a later run; :meth:`_Work.using` checks the current ones). Adding a run merges it with the
    runs before it while they are not twice as long, so a look-up searches a few runs and the merges cost
    ``O(n log n)`` over all the rescoring.
    """

    runs: list[tuple[NDArray[np.int16], NDArray[np.intp]]]

    @classmethod
    def of(cls, assoc_v: NDArray[np.int16], rows: NDArray[np.intp], held: NDArray[np.intp] | None = None) -> BoxUsers:
        """The index of the associations ``assoc_v`` (M, K) of the rows ``rows`` (M,) (``held``: see :meth:`add`)."""
        users = cls([])
        users.add(assoc_v, rows, held)
        return users

    def add(self, assoc_v: NDArray[np.int16], rows: NDArray[np.intp], held: NDArray[np.intp] | None = None) -> None:
        """Index the associations ``assoc_v`` (M, K) of the rows ``rows`` (M,); ``held``, optional: the flat indices
        into (M, K) of every hypothesis that holds a box in some view (:func:`_holders`), where to look."""
        flat, k = assoc_v.reshape(-1), assoc_v.shape[1]
        cells = np.flatnonzero(flat >= 0) if held is None else held[flat[held] >= 0]
        js = flat[cells]
        order = np.argsort(js, kind="stable")
        cells = cells[order]
        self.runs.append((js[order], rows[cells // k] * k + cells % k))
        while len(self.runs) >= 2 and len(self.runs[-2][0]) <= 2 * len(self.runs[-1][0]):
            (j1, r1), (j2, r2) = self.runs.pop(), self.runs.pop()
            js, rs = np.concatenate([j2, j1]), np.concatenate([r2, r1])
            order = np.argsort(js, kind="stable")
            self.runs.append((js[order], rs[order]))

    def hypotheses(self, boxes: NDArray[np.intp]) -> NDArray[np.intp]:
        """Hypotheses (flat indices ``row * K + bin``) indexed with one of ``boxes`` (repeats possible; some no longer
        use it)."""
        out = []
        keys = np.asarray(boxes).astype(np.int16)  # in the runs' type: a key of another type would convert each run
        for js, rs in self.runs:
            lo, hi = np.searchsorted(js, keys, side="left"), np.searchsorted(js, keys, side="right")
            out += [rs[a:b] for a, b in zip(lo, hi)]
        return np.concatenate(out) if out else np.zeros(0, dtype=np.intp)


def best_accepted(candidates: list[Found | None]) -> Found | None:
    """The best-scoring of the look-ahead's refined candidates (None: refused), None if every one was refused."""
    accepted = [c for c in candidates if c is not None]
    return max(accepted, key=lambda o: o.score) if accepted else None


def still_valid(problem: Problem, cache: dict[Any, Found | None], taken_obj: Found) -> dict[Any, Found | None]:
    """The cached refined candidates that stay valid once ``taken_obj`` is taken: accepted, and sharing no box with it."""
    mine = boxes_of(problem, taken_obj)
    return {key: o for key, o in cache.items() if o is not None and o is not taken_obj and not mine & boxes_of(problem, o)}
