"""The paper's method (MonoVisual3DFilter): the dense and sparse drivers and their :class:`Result`.

- dense (default): :class:`~monovisual3d.methods.paper.filter.HistogramFilter` over the paper's grid, view by
  view, then k-means (:mod:`~monovisual3d.methods.paper.kmeans`); the per-view update runs on
  ``PaperConfig.backend`` (compiled numba by default, the numpy reference, or torch);
- sparse (``refine_to``): the coarse-to-fine active set of :mod:`monovisual3d.methods.paper.engine.sparse`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ...grid import VoxelGrid
from ...result import Result
from ...session import Session, View
from .config import PaperConfig
from .engine.sparse import DEFAULT_MAX_CELLS, SparseHistogramFilter
from .filter import HistogramFilter
from .kmeans import choose_k, kmeans_objects

#: Working bytes per active cell of the sparse path (indices, values, children during a split, k-means).
SPARSE_BYTES_PER_CELL = 256


def run(session: Session, config: PaperConfig, *, progress: Callable[[int, int], None] | None = None) -> Result:
    """The paper's histogram filter + k-means on one session (see :class:`PaperConfig` for the options)."""
    if config.refine_to is not None:
        return run_sparse(
            session, config, progress=progress, max_cells=min(DEFAULT_MAX_CELLS, int(config.max_memory) // SPARSE_BYTES_PER_CELL)
        )
    t0 = time.perf_counter()
    filt = HistogramFilter(session.camera, config, workspace=session.workspace)
    for i, view in enumerate(session.views):
        filt.update(view)
        if progress is not None:
            progress(i + 1, len(session.views))
    t1 = time.perf_counter()
    objects = filt.estimate()
    t2 = time.perf_counter()
    if not filt.views_used:
        filt.messages.append("no view had a usable detection: nothing localised")
    grid = filt.grid.to_dict() if filt.grid is not None else {}
    return paper_result(objects, grid, config, (t0, t1, t2), list(filt.messages))


def paper_result(
    objects: list[Any],
    grid: dict[str, Any],
    config: PaperConfig,
    times: tuple[float, float, float],
    warnings: list[str],
    diagnostics: dict[str, Any] | None = None,
) -> Result:
    """The paper method's :class:`Result` (dense and sparse paths): times are (start, filtered, estimated)."""
    t0, t1, t2 = times
    cfg = {k: (v if not isinstance(v, np.generic) else v.item()) for k, v in config.__dict__.items()}
    return Result(
        objects=objects,
        method="paper",
        grid=grid,
        timing_s={"filter": t1 - t0, "estimate": t2 - t1, "total": t2 - t0},
        config=cfg,
        warnings=warnings,
        diagnostics=diagnostics or {},
    )


def run_sparse(
    session: Session,
    config: Any,
    *,
    progress: Callable[[int, int], None] | None = None,
    coarse_resolution: float | None = None,
    threshold: float | None = None,
    max_cells: int = DEFAULT_MAX_CELLS,
) -> Result:
    """The paper's method on an active set refined to ``config.refine_to`` (:mod:`monovisual3d.methods.paper.engine.sparse`).

    The fine grid follows the paper's policy (workspace box, or a cube of side
    ``2 * reach`` in front of the first camera with a detection) at
    ``refine_to``; the root level is ``config.resolution`` rounded to a
    power-of-two multiple of it. Objects come from the same k-means step as
    the dense method, run on the active cells. The active-set threshold
    defaults to ``keep_threshold / 100``: every cell that k-means would use is
    kept with its exact value; object scores are shares of the active mass.
    """
    if threshold is None:
        threshold = 0.01 * float(config.keep_threshold)
    t0 = time.perf_counter()
    grid, with_boxes, messages = _sparse_grid(session, config)

    def make_filter() -> SparseHistogramFilter:
        return SparseHistogramFilter(
            session.camera,
            grid,  # type: ignore[arg-type]  # not None: only called with views that have boxes
            kernel=config.kernel,
            sigma_fraction=config.sigma_fraction,
            coarse_resolution=coarse_resolution or config.resolution,
            threshold=threshold,
            max_cells=max_cells,
        )

    filt, counts = _sparse_filter(make_filter, with_boxes, messages) if grid is not None and with_boxes else (None, [])
    if progress is not None:
        progress(len(session.views), len(session.views))
    t1 = time.perf_counter()
    objects, stats = _sparse_objects(filt, counts, config, max_cells, messages)
    t2 = time.perf_counter()
    grid_dict = grid.to_dict() if grid is not None else {}
    return paper_result(objects, grid_dict, config, (t0, t1, t2), messages, diagnostics={"sparse": dict(stats)})


def _sparse_grid(session: Session, config: Any) -> tuple[VoxelGrid | None, list[tuple[int, View]], list[str]]:
    """The fine grid (workspace, else the paper's cube at the first view with a detection), the views with boxes, messages."""
    fine = float(config.refine_to)
    grid = None
    if session.workspace is not None:
        grid = VoxelGrid.from_bounds(session.workspace.min, session.workspace.max, fine, max_bytes=2**62)
    messages: list[str] = []
    with_boxes: list[tuple[int, View]] = []
    for i, view in enumerate(session.views):
        if not view.detections:
            messages.append(f"views[{i}]: no detections, skipped by the paper method")
            continue
        if grid is None:
            grid = VoxelGrid.in_front_of_camera(view.T_base_optical, fine, config.reach, max_bytes=2**62)
        with_boxes.append((i, view))
    return grid, with_boxes, messages


def _sparse_filter(
    make_filter: Callable[[], SparseHistogramFilter], with_boxes: list[tuple[int, View]], messages: list[str]
) -> tuple[SparseHistogramFilter, list[int]]:
    """Fold the views with boxes into a sparse filter (appends to ``messages``); returns it and the views' box counts.

    All views go into one refinement, so that no view is refined for nothing. When
    some view contradicts the others (nothing stays active), the views are folded in
    again one by one, and a view that contradicts the previous ones is skipped, as
    the dense filter does.
    """
    filt = make_filter()
    for _, view in with_boxes:
        filt.add(view)
    if filt.state is not None and filt.state.n_active > 0:
        return filt, [len(v.detections) for _, v in with_boxes]
    filt = make_filter()
    counts: list[int] = []
    for i, view in with_boxes:
        if filt.update(view):
            counts.append(len(view.detections))
        else:
            messages.append(f"views[{i}]: no grid cell is consistent with this view's boxes and the previous views; view skipped")
    return filt, counts


def _sparse_objects(
    filt: SparseHistogramFilter | None, counts: list[int], config: Any, max_cells: int, messages: list[str]
) -> tuple[list[Any], dict[str, Any]]:
    """k-means over the active cells (appends to ``messages``); returns the objects and the active set's statistics."""
    if filt is None or filt.state is None:
        messages.append("no view had a usable detection: nothing localised")
        return [], {}
    state = filt.state
    stats = state.stats
    if not stats["complete"]:
        messages.append(
            f"refine_to: the active set exceeded max_cells={max_cells:,}; refinement stopped at {1000 * stats['final_resolution_m']:g} mm"
        )
    k = choose_k(counts, config.k)
    objects = kmeans_objects(
        state,  # type: ignore[arg-type]  # duck-typed: kmeans_objects only calls centres_base(index)
        state.posterior(),
        k,
        centre=config.centre,
        keep_threshold=config.keep_threshold,
        weighted_kmeans=config.weighted_kmeans,
    )
    return objects, stats
