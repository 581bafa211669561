"""How the fused numba update scales with views per pass and with boxes per view (Gaussian kernel)."""

from __future__ import annotations

from functools import partial
from typing import Any

from .timing import time_call
from .update_cases import bench_scene, paper_grid, run_state


def update_scaling(edge: int, repeats: int, quick: bool) -> dict[str, Any]:
    """Fused numba (Gaussian): time per update against views per pass and boxes per view."""
    from ..methods.paper.engine.dense import DenseHistogram

    out: dict[str, Any] = {"edge": edge, "kernel": "gaussian", "views": [], "boxes": []}
    for nv in (1, 3, 9) if not quick else (1, 3):
        camera, views = bench_scene(n_views=nv)
        grid = paper_grid(views, edge)

        h = DenseHistogram(grid)
        ts = time_call(partial(run_state, h, camera, views, False), repeats)
        tb = time_call(partial(run_state, h, camera, views, True), repeats)
        out["views"].append(
            {"views": nv, "cells": grid.n_cells, "sequential_ms": ts.summary(1e3), "one_pass_ms": tb.summary(1e3)}
        )
    for nb in (1, 6, 24) if not quick else (1, 6):
        camera, views = bench_scene(n_boxes=nb)
        grid = paper_grid(views, edge)

        t = time_call(partial(run_state, DenseHistogram(grid), camera, views, False), repeats)
        out["boxes"].append({"boxes": nb, "cells": grid.n_cells, "per_view_ms": t.summary(1e3 / len(views))})
    return out
