"""Sparse, coarse-to-fine histogram updates: fine resolution without a dense fine grid.

The paper's posterior over a grid of resolution ``res`` is, for a uniform
prior, ``p(c) ∝ f(c) = prod_v L_v(c)`` at the cell centres ``c`` (the maximum
normalisations of Algorithm 1 cancel). Almost all cells are negligible after
a few views, so instead of a dense grid this module keeps an *active set*.

Algorithm (branch and bound over an octree)
-------------------------------------------
The fine grid of resolution ``res`` is covered by octree cells at ``scale =
2**level`` fine cells per edge (the root level is ``res * 2**levels``, e.g.
16 mm above 1 mm). Starting with every root cell, for each level:

1. every candidate cell gets, against *all* views so far, an upper bound of
   ``log f`` over the fine cell centres it contains (the projections of the
   cell are bounded by interval arithmetic, see
   :func:`~monovisual3d.methods.paper.engine.numba_kernels.pixel_bounds`) and the value of
   ``log f`` at one fine cell inside it;
2. ``M``, the largest such value seen so far, is a lower bound of the fine
   maximum, so a cell whose upper bound is below ``threshold * M`` contains
   no fine cell above ``threshold * max f``: it is dropped;
3. the kept cells are split into their 8 children (clipped to the grid).

At the fine level the values are exact, and the cells kept are **exactly the
fine cells with** ``f >= threshold * max f`` (with the dense grid's values), no
matter how coarse the root. What is dropped is below ``threshold`` of the
maximum per cell.

Memory is bounded by ``max_cells``: when the children of a level would exceed
it, refinement stops at that level (the active cells then carry the value at
one fine cell each) and :attr:`SparsePosterior.stats` says so
(``"complete": False``). The peak memory is reported in bytes.

The same octree evaluation serves any per-view likelihood that has a point
value and an upper bound over a box of space; only the kernel functions of
:mod:`~monovisual3d.methods.paper.engine.numba_kernels` are specific to the paper.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ....camera import Camera
from ....errors import InputError
from ....frames import transform_points
from ....grid import VoxelGrid
from ....kernels.threads import kernel_threads
from ....session import View
from .dense import numba_kernels
from .params import DEFAULT_GAUSS_EPS, PackedViews, pack_views

#: Default relative threshold of the active set: cells below threshold * max are dropped.
DEFAULT_THRESHOLD = 1e-6
#: Default cap on the number of candidate cells held at once (about 40 bytes each).
DEFAULT_MAX_CELLS = 8_000_000
#: Bytes held per candidate cell: indices (3 x int32) + point and bound (2 x float64) + keep mask.
BYTES_PER_CANDIDATE = 3 * 4 + 2 * 8 + 1
#: Single-thread cost of one candidate cell against one box in ``octree_eval`` (point value and bound),
#: nanoseconds; the thread count's work estimate.
NS_PER_CELL_BOX = 10.0
#: Slack on the bound test (log units) covering the rounding of exp(); keeps the guarantee exact.
_LOG_SLACK = 1e-9


@dataclass
class SparsePosterior:
    """The active set of a coarse-to-fine posterior.

    Attributes
    ----------
    grid : VoxelGrid, the fine grid (never allocated densely)
    level : int, octree level of the active cells (0: fine cells)
    ijk : ndarray, shape (M, 3), int32, active cell indices at that level
    log_f : ndarray, shape (M,), float64, ``sum_v log L_v`` at one fine cell of each active cell
        (its centre when level is 0)
    stats : dict, per-level counts, memory, timing and whether the refinement was complete
    """

    grid: VoxelGrid
    level: int
    ijk: NDArray[np.int32]
    log_f: NDArray[np.float64]
    stats: dict[str, Any] = field(default_factory=dict)

    @property
    def n_active(self) -> int:
        return int(len(self.log_f))

    @property
    def resolution(self) -> float:
        """Edge of the active cells, metres."""
        return self.grid.resolution * 2**self.level

    def fine_ijk(self) -> NDArray[np.int64]:
        """Indices on the fine grid of the cells where ``log_f`` was evaluated, shape (M, 3)."""
        s = 2**self.level
        shape = np.asarray(self.grid.shape)
        return np.minimum(self.ijk.astype(np.int64) * s + s // 2, np.minimum(self.ijk.astype(np.int64) * s + s, shape) - 1)

    def posterior(self) -> NDArray[np.float64]:
        """Weights of the active cells, shape (M,), summing to 1 (uniform prior, equal cell volumes)."""
        if self.n_active == 0:
            return np.zeros(0)
        w = np.exp(self.log_f - self.log_f.max())
        return w / w.sum()

    def centres_base(self, index: NDArray[np.integer] | None = None) -> NDArray[np.float64]:
        """Base-frame centres of the evaluated fine cells, shape (M, 3) (or of ``index`` of them)."""
        ijk = self.fine_ijk() if index is None else self.fine_ijk()[np.asarray(index)]
        return transform_points(self.grid.T_base_grid, (ijk + 0.5) * self.grid.resolution)

    def to_dense(self) -> NDArray[np.float64]:
        """Posterior on the dense fine grid (zero outside the active set); for small grids and tests."""
        out = np.zeros(self.grid.shape)
        if self.level != 0:
            raise InputError("to_dense: the refinement stopped above the fine level (see stats['complete'])")
        p = self.posterior()
        out[tuple(self.ijk.T.astype(np.int64))] = p
        return out


def _root_cells(shape: tuple[int, int, int], levels: int) -> NDArray[np.int32]:
    s = 2**levels
    n = [-(-int(d) // s) for d in shape]
    i, j, k = np.meshgrid(*(np.arange(d, dtype=np.int32) for d in n), indexing="ij")
    return np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1)


def _children(ijk: NDArray[np.int32], level: int, shape: tuple[int, int, int]) -> NDArray[np.int32]:
    """The 8 children of each cell, dropping those outside the fine grid."""
    offs = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)], dtype=np.int32)
    ch = (2 * ijk[:, None, :] + offs[None]).reshape(-1, 3)
    s = 2 ** (level - 1)
    inside = np.all(ch.astype(np.int64) * s < np.asarray(shape), axis=1)
    return ch[inside]


#: Children of an octree cell (2 per axis).
_CHILDREN_PER_CELL = 8


def refine(
    grid: VoxelGrid,
    packed: PackedViews,
    levels: int,
    *,
    threshold: float = DEFAULT_THRESHOLD,
    max_cells: int = DEFAULT_MAX_CELLS,
) -> SparsePosterior:
    """Branch-and-bound refinement from ``res * 2**levels`` down to the grid's resolution.

    Parameters
    ----------
    grid : VoxelGrid, the fine grid
    packed : PackedViews, all views so far (see :func:`~monovisual3d.methods.paper.engine.params.pack_views`)
    levels : int >= 0, octree levels above the fine grid
    threshold : float in (0, 1), relative threshold of the active set
    max_cells : int, most candidate cells held at once

    Returns
    -------
    SparsePosterior

    Notes
    -----
    One unit of thought: one loop over levels, kept whole; the running lower bound ``best``, the
    candidates and the counters it updates are the branch-and-bound's state, and splitting the loop
    would pass them all back and forth.
    """
    if not (0.0 < threshold < 1.0):
        raise InputError(f"threshold: got {threshold}, expected a value in (0, 1)")
    if levels < 0:
        raise InputError(f"levels: got {levels}, expected >= 0")
    nk = numba_kernels()
    t0 = time.perf_counter()
    shape = np.asarray(grid.shape, dtype=np.int64)
    log_thr = math.log(threshold)
    cells = _root_cells(grid.shape, levels)
    best = -np.inf  # lower bound of max log f on the fine lattice
    per_level: list[dict[str, Any]] = []
    peak = 0
    complete = True
    level = levels
    point = np.zeros(0)
    while True:
        n = len(cells)
        point = np.empty(n)
        upper = np.empty(n)
        with kernel_threads(int(NS_PER_CELL_BOX * n * len(packed.box_params))):
            nk.octree_eval(cells, 2**level, grid.resolution, shape, 0, packed.n_views, packed, best + log_thr - 1.0, point, upper)
        if n:
            best = max(best, float(point.max()))
        # without a positive point value yet (best = -inf) only cells whose bound is zero can go
        keep = upper + _LOG_SLACK >= best + log_thr if np.isfinite(best) else upper > -np.inf
        peak = max(peak, n * BYTES_PER_CANDIDATE)
        kept = int(keep.sum())
        per_level.append({"level": level, "resolution_m": grid.resolution * 2**level, "candidates": n, "kept": kept})
        cells, point = cells[keep], point[keep]
        if level == 0 or kept == 0:
            break
        if kept * _CHILDREN_PER_CELL > max_cells:
            complete = False
            break
        cells = _children(cells, level, grid.shape)
        level -= 1
    stats = {
        "levels": per_level,
        "threshold": threshold,
        "complete": complete and (level == 0 or len(cells) == 0),
        "final_resolution_m": grid.resolution * 2**level,
        "active_cells": int(len(cells)),
        "peak_bytes": int(peak),
        "max_cells": int(max_cells),
        "time_s": time.perf_counter() - t0,
    }
    return SparsePosterior(grid=grid, level=level, ijk=cells, log_f=point, stats=stats)


def levels_between(coarse_resolution: float, fine_resolution: float) -> int:
    """Octree levels so that ``fine * 2**levels`` is the power-of-two multiple nearest ``coarse`` (>= 0).

    Examples
    --------
    >>> levels_between(0.016, 0.001), levels_between(0.01, 0.001), levels_between(0.001, 0.002)
    (4, 3, 0)
    """
    if not (coarse_resolution > 0 and fine_resolution > 0):
        raise InputError("levels_between: resolutions must be positive")
    return max(0, int(round(math.log2(coarse_resolution / fine_resolution))))


class SparseHistogramFilter:
    """Incremental coarse-to-fine filter: the paper's posterior at ``refine_to`` on an active set.

    The refinement runs lazily: :meth:`add` only records a view, and
    :attr:`state` re-runs the branch and bound of :func:`refine` from the root
    against all views so far when it is read after a change (the root level
    is cheap; deeper levels hold only cells that can matter). :meth:`update`
    adds a view and refines at once, so that a view that leaves no active cell
    is skipped, as in :class:`~monovisual3d.methods.paper.filter.HistogramFilter`.

    Parameters
    ----------
    camera : Camera
    grid : VoxelGrid, the fine grid (only its pose, shape and resolution are used)
    kernel, sigma_fraction : the paper's kernel options
    coarse_resolution : float, metres, root cell size (rounded to ``res * 2**levels``)
    threshold : float, relative threshold of the active set
    max_cells : int, memory cap (candidate cells)
    gauss_eps : float, Gaussian cut-off

    Examples
    --------
    >>> from monovisual3d.session import Detection
    >>> g = VoxelGrid.from_bounds([-0.05, -0.05, 0.45], [0.05, 0.05, 0.55], 0.002)
    >>> f = SparseHistogramFilter(Camera.from_hfov(640, 480, 69.0), g, kernel="square", coarse_resolution=0.016)
    >>> f.update(View(np.eye(4), (Detection(np.array([310.0, 230.0, 330.0, 250.0])),)))
    True
    >>> f.state.level, f.state.n_active > 0
    (0, True)
    """

    def __init__(
        self,
        camera: Camera,
        grid: VoxelGrid,
        *,
        kernel: str = "gaussian",
        sigma_fraction: float = 0.5,
        coarse_resolution: float = 0.016,
        threshold: float = DEFAULT_THRESHOLD,
        max_cells: int = DEFAULT_MAX_CELLS,
        gauss_eps: float = DEFAULT_GAUSS_EPS,
    ) -> None:
        self.camera = camera
        self.grid = grid
        self.kernel = kernel
        self.sigma_fraction = float(sigma_fraction)
        self.levels = levels_between(coarse_resolution, grid.resolution)
        self.threshold = float(threshold)
        self.max_cells = int(max_cells)
        self.gauss_eps = float(gauss_eps)
        self.views: list[View] = []
        self._state: SparsePosterior | None = None
        self._stale = False

    def _refine(self, views: Sequence[View]) -> SparsePosterior:
        packed = pack_views(self.grid, self.camera, views, self.kernel, self.sigma_fraction, self.gauss_eps)
        return refine(self.grid, packed, self.levels, threshold=self.threshold, max_cells=self.max_cells)

    @property
    def state(self) -> SparsePosterior | None:
        """The active set after all views so far (None before the first view)."""
        if self._stale and self.views:
            self._state = self._refine(self.views)
            self._stale = False
        return self._state

    def add(self, view: View) -> bool:
        """Record a view without refining (False, and nothing recorded, without detections)."""
        if not view.detections:
            return False
        self.views.append(view)
        self._stale = True
        return True

    def update(self, view: View) -> bool:
        """Fold one view in now; False (view skipped) without detections or when no cell survives."""
        if not view.detections:
            return False
        state = self._refine([*self.views, view])
        if state.n_active == 0:
            return False
        self.views.append(view)
        self._state = state
        self._stale = False
        return True
