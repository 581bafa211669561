"""Coarse-to-fine search of the (cell, shape bin) hypotheses that can hold an object.

A shape bin is a sphere (one of ``BayesConfig.radii``) or a spheroid
(a radius times an elongation of ``BayesConfig.elongations`` along its axis):
``BayesConfig.hypothesis_bins``, axes ``BayesConfig.hypothesis_axes``. Man-made
containers, bottles and hanging fruit stand (or hang) along gravity, so an
elongated object's box is explained by an upright spheroid from the first
level; a sphere would only match it with two edges at their floors and score
too low to be kept. An object lying on its side (a can, a box, a tray) has a
wide box that neither explains: the lying bins (``BayesConfig.lying_yaws``
horizontal axes) do. Elongated bins are scored at the first level only where a
sphere bin passes, and dropped where a sphere explains the box better
(:func:`_plausible_shapes`).

A cell can hold an object only if, in at least ``min_views`` views, its
centre projects inside one of the boxes, widened by half the box size on
each side (room for partial occlusion) plus the cell's own projected
half-diagonal (:func:`monovisual3d.grid.cone_counts`). Surviving cells are
scored with every radius bin (:func:`.scoring.score_hypotheses`); cells whose
best score is below ``accept - prune_slack`` are dropped and the rest are split
into 8 children, until the target resolution is reached. The cost grows with
the volume of the viewing-cone intersections, not with the workspace. Where the
last level would be large (:data:`LAZY_LAST_LEVEL_ABOVE`), the search stops one
level above it and the extraction splits a cell only when it nears the best
(:func:`.extract.extract`): most cells of a dense row are ghost crossings whose
boxes are taken before they get there.

Explaining away starts in the search (:func:`box_dominated`): a hypothesis
whose every box is also used by another hypothesis scoring ``dominance_margin``
nats more is dropped. Whichever object takes those boxes takes this
hypothesis's support with it, and until then the other is always preferred, so
it could only matter if that other were rejected. In a dense row most cone
crossings are such ghosts (two boxes of two different fruit, each box already
the best-explained box of its own fruit), and the hypotheses kept grow with the
fruit, not with the square of the boxes.

Memory is bounded by ``max_memory``: the first level is made coarser (by powers
of two, so the last level is still ``resolution``) until the workspace has at
most :data:`MAX_FIRST_LEVEL_CELLS` cells. Levels coarser than ``search_start``
use cone counts only (a score blurred over metres says nothing). A level with
more hypotheses than fit is scored in chunks keeping the best-scoring cells
(``Hypotheses.capped``); the last level is left to the extraction only when all
of it fits (the extraction may hold it all), so a capped last level is scored here.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ...grid import VoxelGrid, cell_half_diagonal, split_cells
from ._kernels import box_dominated_fused
from .hypotheses import cone_counts_at, cone_counts_within, level_mask
from .problem import Problem
from .scoring import score_hypotheses
from .state import Hypotheses, Scores, State

#: Cells of the first search level at most (chosen so the first level takes well under a second).
MAX_FIRST_LEVEL_CELLS = 2_000_000
#: Boxes may be this much larger than the silhouette (noise) in the depth gate of the coarse levels.
DEPTH_GATE_SLACK = 2.0
#: Hypotheses of the last level above which the search leaves that level to the extraction, which scores a cell's
#: children only when the cell nears the best. Scoring the whole level at once is one parallel kernel call; the
#: extraction's splits are many small ones and pay off only where most cells are ghost crossings it never splits: in
#: dense rows of many fruit (why: docs/decisions/bayes-search.md#lazy_last_level_above).
LAZY_LAST_LEVEL_ABOVE = 200_000
#: Cells whose cone counts are computed at once.
CHUNK_CELLS = 1 << 20
#: A box at least this much wider than tall (width / height) may be a lying object's: the first level scores the lying
#: bins only in cells whose passing sphere bins use such a box. A lying 12 x 5 x 5 cm object seen within 30 degrees of
#: broadside gives about 2, a sphere's box stays below 1.25 out to the corners of a 70 degree field of view, and an
#: object seen along its long axis gives a near-square box that a sphere of its across-radius already explains.
LYING_MIN_BOX_ASPECT = 1.3
#: Views with such a wide box a cell needs before its lying bins are scored: a lying object seen from two sides of its
#: broadside is wide in both, a fruit a neighbour cuts in one view is wide in that one only (in a dense row, one in
#: two fruit; their lying bins cost a quarter of the search there and explained nothing).
MIN_WIDE_VIEWS = 2


def bytes_per_hypothesis(n_views: int) -> int:
    """Working memory of one scored hypothesis: the score arrays, the extraction's copy and temporaries."""
    return 2 * (8 + 4 + 2 * n_views + 1) + 16


def hypothesis_cap(problem: Problem) -> int:
    """Hypotheses one level may hold: ``max_hypotheses``, lowered to half the memory budget."""
    cfg = problem.config
    budget = int(cfg.max_memory) // 2 // bytes_per_hypothesis(len(problem.views))
    return max(len(cfg.hypothesis_bins[0]), min(cfg.tuning.max_hypotheses, budget))


def first_level(grid: VoxelGrid, start: float, resolution: float, max_cells: int = MAX_FIRST_LEVEL_CELLS) -> VoxelGrid:
    """The grid of the first level over ``grid``'s region: cell ``start * 2**m``, the smallest with <= ``max_cells`` cells.

    Doubling keeps the halving levels landing on ``resolution``.
    """
    size = np.asarray(grid.shape, dtype=float) * grid.resolution
    cell = float(start)
    while math.prod(max(1, math.ceil(s / cell - 1e-9)) for s in size) > max_cells:
        cell *= 2
    shape = tuple(max(1, math.ceil(s / cell - 1e-9)) for s in size)
    del resolution  # the level sizes are start / 2**i, so any start >= resolution ends at it
    return VoxelGrid(grid.T_base_grid, shape, cell)  # type: ignore[arg-type]


def size_gated_counts(problem: Problem, centres_base: NDArray[np.float64], half_diagonal: float) -> NDArray[np.int32]:
    """:func:`monovisual3d.grid.cone_counts` with a depth gate per box: the numpy pass of the coarse levels.

    A box is at most as large as the silhouette of its object (occlusion only shrinks it), so an
    object of radius <= ``radius_max`` seen in a box of largest side ``s`` pixels lies at depth
    ``z <= 2 f radius_max / s``; :data:`DEPTH_GATE_SLACK` leaves room for box noise. The gate keeps
    a huge workspace from being searched out to its far end along every viewing cone.
    """
    cam, cfg = problem.camera, problem.config
    f = max(cam.fx, cam.fy)
    counts = np.zeros(len(centres_base), dtype=np.int32)
    for vd in problem.views:
        p_opt = centres_base @ vd.T_optical_base[:3, :3].T + vd.T_optical_base[:3, 3]
        z = p_opt[:, 2]
        front = z > 1e-6
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = cam.project(np.where(front[:, None], p_opt, [0.0, 0.0, 1.0]))
            margin = np.where(front, f * half_diagonal / np.maximum(z, 1e-6), np.inf) + 2.0
        inside = (z > -half_diagonal) & ~front  # a region reaching behind the camera gets the benefit of the doubt
        for x1, y1, x2, y2 in vd.boxes:
            wx, wy = 0.5 * (x2 - x1), 0.5 * (y2 - y1)
            z_max = DEPTH_GATE_SLACK * 2 * f * float(cfg.hypothesis_bins[1].max()) / max(x2 - x1, y2 - y1, 1.0) + half_diagonal
            u, v = uv[:, 0], uv[:, 1]
            inside |= (
                (u >= x1 - wx - margin)
                & (u <= x2 + wx + margin)
                & (v >= y1 - wy - margin)
                & (v <= y2 + wy + margin)
                & (z <= z_max)
                & front
            )
        counts += inside.astype(np.int32)
    return counts


def _first_cells(problem: Problem, grid: VoxelGrid) -> NDArray[np.float64]:
    """Centres (grid frame) of the first level's cells inside at least ``min_views`` cones, computed in chunks.

    A first level coarser than ``search_start`` (a huge workspace) uses the depth-gated counts.
    """
    R, t = grid.T_base_grid[:3, :3], grid.T_base_grid[:3, 3]
    half = cell_half_diagonal(grid.resolution)
    coarse = grid.resolution > problem.config.search_start * (1 + 1e-9)
    kept = []
    for start in range(0, grid.n_cells, CHUNK_CELLS):
        c_grid = grid.centres_grid(np.arange(start, min(start + CHUNK_CELLS, grid.n_cells)))
        c_base = c_grid @ R.T + t
        counts = size_gated_counts(problem, c_base, half) if coarse else cone_counts_within(problem, c_base, half)
        kept.append(c_grid[counts >= problem.config.min_views])
    return np.concatenate(kept) if kept else np.zeros((0, 3))


def _score_level(
    problem: Problem, centres: NDArray[np.float64], cell: float, mask: NDArray[np.bool_], cap: int
) -> tuple[NDArray[np.intp], Scores, bool]:
    """Score a level; with more than ``cap`` hypotheses, in chunks keeping the ``cap // K`` best cells.

    Returns the rows kept (indices into ``centres``), their scores and whether cells were dropped.
    """
    radii, semi_up = problem.config.hypothesis_bins
    axes = problem.config.hypothesis_axes
    max_cells = max(1, cap // len(radii))
    if len(centres) <= max_cells:
        return np.arange(len(centres)), score_hypotheses(problem, frozenset(), centres, radii, cell, mask, semi_up, axes), False
    rows = np.zeros(0, dtype=np.intp)
    best: Scores | None = None
    for start in range(0, len(centres), max_cells):
        idx = np.arange(start, min(start + max_cells, len(centres)))
        sc = score_hypotheses(problem, frozenset(), centres[idx], radii, cell, mask[idx], semi_up, axes)
        if best is not None:
            idx = np.concatenate([rows, idx])
            sc = (np.concatenate([best[0], sc[0]]), np.concatenate([best[1], sc[1]]), np.concatenate([best[2], sc[2]], axis=1))
        top = np.argsort(-sc[0].max(axis=1), kind="stable")[:max_cells]
        rows, best = idx[top], (sc[0][top], sc[1][top], sc[2][:, top])
    assert best is not None
    order = np.argsort(rows, kind="stable")  # keep the cells in grid order, as without the cap
    return rows[order], (best[0][order], best[1][order], best[2][:, order]), True


def box_dominated(total: NDArray[np.float64], assoc: NDArray[np.int16], n_boxes: list[int], margin: float) -> NDArray[np.bool_]:
    """Hypotheses whose every associated box is used by another hypothesis scoring more than ``margin`` above them.

    Parameters
    ----------
    total : ndarray, shape (N, K), nats (-inf: not scored)
    assoc : ndarray, shape (V, N, K), int16: associated box per view, -1 for none
    n_boxes : list of int, length V: boxes per view
    margin : float, nats (inf: nothing is dominated)

    Returns
    -------
    ndarray, shape (N, K), bool; False for a hypothesis with no box

    Examples
    --------
    >>> total = np.array([[20.0], [9.0], [15.0]])
    >>> assoc = np.array([[[0], [0], [1]], [[0], [1], [1]]], dtype=np.int16)  # view 0 and view 1
    >>> box_dominated(total, assoc, [2, 2], 10.0).ravel().tolist()
    [False, False, False]
    >>> box_dominated(total, assoc, [2, 2], 5.0).ravel().tolist()
    [False, True, False]
    """
    flat = total.reshape(-1)
    out = np.ones(flat.shape, dtype=bool)
    used = np.zeros(flat.shape, dtype=bool)
    if not math.isfinite(margin):
        return np.zeros(total.shape, dtype=bool)
    scored = np.isfinite(flat)
    for v, n in enumerate(n_boxes):
        a = assoc[v].reshape(-1)
        use = np.flatnonzero((a >= 0) & scored)
        best = np.full(n, -np.inf)
        np.maximum.at(best, a[use], flat[use])  # the best score of any hypothesis using each box
        out[use] &= flat[use] < best[a[use]] - margin
        used[use] = True
    return (out & used).reshape(total.shape)


def _box_dominated(
    problem: Problem, total: NDArray[np.float64], assoc: NDArray[np.int16], n_boxes: list[int]
) -> NDArray[np.bool_]:
    """:func:`box_dominated` with the problem's margin, compiled with the numba backend."""
    if problem.config.backend == "numba":
        return box_dominated_fused(total, assoc, n_boxes, problem.config.tuning.dominance_margin)
    return box_dominated(total, assoc, n_boxes, problem.config.tuning.dominance_margin)


def _widen(mask: NDArray[np.bool_], bins: int) -> NDArray[np.bool_]:
    """Each row's kept radius bins, widened by ``bins`` on each side."""
    for _ in range(bins):
        mask = mask | np.pad(mask[:, 1:], ((0, 0), (0, 1))) | np.pad(mask[:, :-1], ((0, 0), (1, 0)))
    return mask


def lying_bins(problem: Problem) -> NDArray[np.bool_]:
    """Which shape bins lie (their axis perpendicular to ``up``), shape (K,)."""
    cfg = problem.config
    radii, semi_up = cfg.hypothesis_bins
    return (semi_up != radii) & (np.abs(cfg.hypothesis_axes @ cfg.up_vector) < 0.5)


def _wide_box_cells(problem: Problem, scores: Scores, use: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Cells (N,) where one of the hypotheses ``use`` (N, K) associates, in at least :data:`MIN_WIDE_VIEWS` views, a box
    at least :data:`LYING_MIN_BOX_ASPECT` wider than tall."""
    _, _, assoc = scores
    count = np.zeros(use.shape, dtype=np.int32)
    for v, vd in enumerate(problem.views):
        b = vd.boxes.reshape(-1, 4)
        wide = np.append((b[:, 2] - b[:, 0]) >= LYING_MIN_BOX_ASPECT * (b[:, 3] - b[:, 1]), False)  # index -1: no box
        count += wide[assoc[v]] & use
    return (count >= MIN_WIDE_VIEWS).any(axis=1)


def _score_deferred(
    problem: Problem, centres: NDArray[np.float64], cell: float, scores: Scores, sphere_bins: NDArray[np.bool_], floor: float
) -> tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.int16], int]:
    """The first level's elongated bins, scored in the cells where a sphere bin reaches ``floor`` (the lying bins
    only where such a sphere bin uses a wide box, :func:`_wide_box_cells`); -inf elsewhere.

    Returns the level's merged scores and the number of hypotheses scored.
    """
    total, n_assoc, assoc = (a.copy() for a in scores)
    passing = (total >= floor) & sphere_bins
    rows = np.flatnonzero(passing.any(axis=1))
    if len(rows) == 0:
        return total, n_assoc, assoc, 0
    radii, semi_up = problem.config.hypothesis_bins
    lying = lying_bins(problem)
    wide = _wide_box_cells(problem, (total[rows], n_assoc[rows], assoc[:, rows]), passing[rows])
    mask = (~sphere_bins & ~lying)[None, :] | (lying[None, :] & wide[:, None])
    t, n, a = score_hypotheses(
        problem, frozenset(), centres[rows], radii, cell, np.ascontiguousarray(mask), semi_up, problem.config.hypothesis_axes
    )
    cols = np.flatnonzero(~sphere_bins)
    total[np.ix_(rows, cols)], n_assoc[np.ix_(rows, cols)] = t[:, cols], n[:, cols]
    assoc[:, rows[:, None], cols[None, :]] = a[:, :, cols]
    return total, n_assoc, assoc, int(mask.sum())


def _cone_levels(problem: Problem, level: VoxelGrid, cap_cells: int) -> tuple[NDArray[np.float64], float, bool]:
    """Levels coarser than ``search_start`` (a workspace too large for it): cone counts only, no scoring.

    A coarse cell's score is blurred over metres and says nothing, but its cone count is a safe
    bound. Returns the surviving cell centres (grid frame) at the first level of cell size
    ``<= search_start``, that cell size, and whether the cap dropped cells (those in fewest cones).
    """
    cfg = problem.config
    R, t = level.T_base_grid[:3, :3], level.T_base_grid[:3, 3]
    cell, capped = level.resolution, False
    centres_grid = _first_cells(problem, level)
    while cell > cfg.search_start * (1 + 1e-9) and len(centres_grid):
        # the last split lands on search_start, whose cells the scored levels count again without the gate
        centres_grid = split_cells(centres_grid, cell)
        cell /= 2
        counts = size_gated_counts(problem, centres_grid @ R.T + t, cell_half_diagonal(cell))
        keep = np.flatnonzero(counts >= cfg.min_views)
        if len(keep) > cap_cells:
            keep, capped = np.sort(keep[np.argsort(-counts[keep], kind="stable")[:cap_cells]]), True
        centres_grid = centres_grid[keep]
    return centres_grid, cell, capped


def search(problem: Problem, grid: VoxelGrid) -> Hypotheses:
    """Coarse-to-fine search over ``grid``'s region (see the module docstring).

    ``BayesConfig.lazy_last_level`` leaves the last level to the extraction (``Hypotheses.child_cell``); None: when its
    hypotheses (before the cone test of its cells) would be more than :data:`LAZY_LAST_LEVEL_ABOVE`. Never where the
    first scored level is the last, nor where the last level exceeds the hypothesis budget (:func:`hypothesis_cap`).
    """
    cfg = problem.config
    radii, semi_up = cfg.hypothesis_bins
    level = first_level(grid, cfg.search_start, cfg.resolution)
    R, t = level.T_base_grid[:3, :3], level.T_base_grid[:3, 3]
    cap = hypothesis_cap(problem)
    centres_grid, cell, capped = _cone_levels(problem, level, max(1, cap // len(radii)))
    sphere_bins = semi_up == radii
    # the first scored level scores the elongated bins only in the cells its spheres keep: its cell blur is so
    # large that a sphere explains an elongated box nearly as well (the cells of tall objects stay)
    deferred = bool(sphere_bins.any() and not sphere_bins.all())
    mask = np.ones((len(centres_grid), len(radii)), dtype=bool) & (sphere_bins if deferred else True)
    floor = cfg.accept - cfg.tuning.prune_slack
    n_scored, counted = 0, True  # the cells from _cone_levels are already cone-checked at this size
    while True:
        centres = centres_grid @ R.T + t
        if not counted:
            keep = cone_counts_at(problem, centres, cell) >= cfg.min_views
            centres_grid, centres, mask = centres_grid[keep], centres[keep], mask[keep]
        counted = False
        rows, scores, dropped = _score_level(problem, centres, cell, mask, cap)
        capped |= dropped
        centres_grid, centres, mask = centres_grid[rows], centres[rows], mask[rows]
        n_scored += int(mask.sum())
        total, n_assoc, assoc = scores
        if deferred:
            total, n_assoc, assoc, n_more = _score_deferred(problem, centres, cell, scores, sphere_bins, floor)
            mask, n_scored, deferred = mask | ~sphere_bins, n_scored + n_more, False
        n_boxes = [len(vd.boxes) for vd in problem.views]
        mask = level_mask(problem, (total, n_assoc, assoc), _box_dominated(problem, total, assoc, n_boxes))
        good = mask.any(axis=1)
        centres_grid, centres, mask = centres_grid[good], centres[good], mask[good]
        scores = (total[good], n_assoc[good], assoc[:, good])
        axes = cfg.hypothesis_axes
        if cell <= cfg.resolution * (1 + 1e-9) or len(centres) == 0:
            return Hypotheses(centres, radii, cell, scores, mask, n_scored, level.resolution, capped, semi_up, axes)
        # children inherit the radii their parent kept, widened (the parent's score is blurred in position, not radius)
        children_mask = np.repeat(_widen(mask, cfg.tuning.radius_margin_bins), 8, axis=0)  # children of cell i: rows 8i..8i+7
        children_grid = split_cells(centres_grid, cell)
        n_children = int(children_mask.sum())
        lazy = n_children > LAZY_LAST_LEVEL_ABOVE if cfg.tuning.lazy_last_level is None else cfg.tuning.lazy_last_level
        # the extraction holds at most the whole last level: lazily only where that fits the budget (else chunked)
        if cell / 2 <= cfg.resolution * (1 + 1e-9) and lazy and n_children <= cap:
            children = children_grid @ R.T + t
            parent = Hypotheses(centres, radii, cell, scores, mask, n_scored, level.resolution, capped, semi_up, axes)
            return replace(parent, child_cell=cell / 2, children_base=children, children_mask=children_mask)
        centres_grid, mask = children_grid, children_mask
        cell /= 2


def run(problem: Problem, state: State) -> State:
    """The pass: the search over the problem's region."""
    assert problem.region is not None
    return replace(state, hypotheses=search(problem, problem.region))
