"""The sparse coarse-to-fine engine at an effective resolution no dense grid could hold (1 mm over the paper's cube)."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from functools import partial
from typing import Any

from ..camera import Camera
from ..grid import VoxelGrid
from ..session import View
from .timing import time_call
from .update_cases import CUBE_M, SIGMA_FRACTION, run_sparse

#: Root cell size of the coarse-to-fine search, metres (16 mm).
SPARSE_ROOT_M = 0.016
#: Posterior mass below which a sparse cell is not refined.
SPARSE_THRESHOLD = 1e-3
#: ``max_bytes`` of the virtual fine grid (a description: the sparse engine never allocates it).
VIRTUAL_GRID_BYTES = 2**62


def sparse_fine_rows(
    camera: Camera,
    views: list[View],
    kernels: Iterable[str],
    sparse_refine_to: float,
    repeats: int,
    quick: bool,
    say: Callable[[str], None],
) -> list[dict[str, Any]]:
    """Sparse at ``sparse_refine_to`` effective resolution over the paper's cube, one row per kernel."""
    from ..methods.paper.engine.params import pack_views
    from ..methods.paper.engine.sparse import levels_between

    n_v = len(views)
    # sparse at 1 mm effective resolution over the same cube (no dense grid could hold it: 1.7 G cells)
    sparse_fine: list[dict[str, Any]] = []
    fine = VoxelGrid.in_front_of_camera(views[0].T_base_optical, sparse_refine_to, CUBE_M / 2, max_bytes=VIRTUAL_GRID_BYTES)
    for kernel in kernels:
        say(f"sparse {sparse_refine_to * 1e3:g} mm {kernel}")
        packed = pack_views(fine, camera, views, kernel, SIGMA_FRACTION)
        levels = levels_between(SPARSE_ROOT_M, sparse_refine_to)
        last: dict[str, Any] = {}
        t = time_call(partial(run_sparse, fine, packed, levels, SPARSE_THRESHOLD, last), 1 if quick else max(2, repeats // 2))
        st = last["s"].stats
        sparse_fine.append(
            {
                "kernel": kernel,
                "virtual_cells": fine.n_cells,
                "refine_to_mm": sparse_refine_to * 1e3,
                "root_mm": SPARSE_ROOT_M * 1e3,
                "views": n_v,
                "total_ms": t.summary(1e3),
                "per_view_ms": t.summary(1e3 / n_v),
                "threshold": SPARSE_THRESHOLD,
                **{k: st[k] for k in ("active_cells", "peak_bytes", "complete", "final_resolution_m", "levels")},
            }
        )
    return sparse_fine
