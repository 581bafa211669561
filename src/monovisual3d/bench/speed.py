"""Speed benchmark of the histogram update: naive loop, numpy reference, fused numba, sparse, torch.

Scene: the paper's six spheres seen from its three poses
(:func:`monovisual3d.sim.scenes.paper_scene`, :func:`~monovisual3d.sim.viewpoints.paper_poses`),
exact boxes; the grid is the paper's cube of side 1.2 m in front of the first
camera at ``1.2 / n`` m for ``n**3`` cells (0.25 M, 2 M, 16 M).

Methodology: every timed case runs once untimed (warm-up; numba compilation
is cached on disk and excluded), then ``repeats`` times; the table gives the
median and the min-max spread of the wall time, with the CPU time of the
process beside it (less sensitive to other jobs on a shared machine). A "view"
is one update of the posterior; each repetition folds the three views in
order from a uniform prior and the per-view figure is the mean of the three
(``first_view_ms`` is the first one alone: the uniform prior is the worst
case for the engines that skip dead tiles). The naive per-cell loop
(Algorithm 1 in pure Python) is timed on a random subsample of cells and
extrapolated linearly. Memory: the engine's own state (bytes per cell) and,
for numpy, the peak of numpy temporaries traced by :mod:`tracemalloc`.
"""

from __future__ import annotations

import math
import statistics
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from ..camera import Camera
from ..grid import VoxelGrid
from ..session import View
from .end_to_end import END_TO_END, end_to_end, format_end_to_end, ms, paper_default_vs_numpy
from .sparse_fine import SPARSE_THRESHOLD, sparse_fine_rows
from .timing import Timing, machine_metadata, time_call
from .update_cases import SIGMA_FRACTION, bench_scene, paper_grid, run_filter_path, run_naive, run_numpy, run_sparse, run_torch
from .update_scaling import update_scaling

#: Grid edges (cells per axis) of the full benchmark: 63**3 = 0.25 M, 126**3 = 2 M, 252**3 = 16 M.
FULL_EDGES = (63, 126, 252)
#: Grid edges of --quick.
QUICK_EDGES = (32, 63)
#: Methods of the headline table, in order.
METHODS = ("naive-python", "numpy", "numba", "numba-filter", "sparse", "torch")
#: Grids above this many cells get fewer repetitions of the slow paths (numpy, naive) and no torch on the CPU.
BIG_GRID_CELLS = 4_000_000
#: Levels of the sparse row at the dense grid's resolution: a root 2**4 = 16 cells up.
SPARSE_LEVELS = 4


def _row(method: str, kernel: str, grid: VoxelGrid, t: Timing, n_views: int, **extra: Any) -> dict[str, Any]:
    per_view = t.summary(1e3 / n_views)
    out = {
        "method": method,
        "kernel": kernel,
        "cells": grid.n_cells,
        "shape": list(grid.shape),
        "resolution_mm": grid.resolution * 1e3,
        "views": n_views,
        "per_view_ms": per_view,
        "cells_per_s": grid.n_cells / (per_view["median"] / 1e3),
    }
    out.update(extra)
    return out


def _naive_row(
    rows: list[dict[str, Any]],
    grid: VoxelGrid,
    camera: Camera,
    views: list[View],
    kernel: str,
    rng: np.random.Generator,
    naive_cells: int,
    once: bool,
) -> None:
    """The per-cell Python loop on a random subsample of cells, extrapolated to the grid."""
    n = grid.n_cells
    cells = rng.choice(n, size=min(naive_cells, n), replace=False)
    prior = np.full(n, 1.0 / n)
    t = time_call(partial(run_naive, grid, camera, views, kernel, cells, prior), 1 if once else 2, warmup=0)
    f = n / len(cells)
    t = Timing([w * f for w in t.wall], [c * f for c in t.cpu])
    rows.append(_row("naive-python", kernel, grid, t, len(views), extrapolated_from_cells=len(cells), state_bytes_per_cell=8))


def _numpy_row(
    rows: list[dict[str, Any]], grid: VoxelGrid, camera: Camera, views: list[View], kernel: str, repeats: int, big: bool
) -> None:
    """The numpy reference; its temporaries are measured with tracemalloc in a separate run."""
    from ..methods.paper.filter import paper_update, paper_view_likelihood_grid

    n = grid.n_cells
    t = time_call(partial(run_numpy, grid, camera, views, kernel), 1 if big else repeats, warmup=0 if big else 1)
    tracemalloc.start()
    tracemalloc.reset_peak()
    p0 = np.full(n, 1.0 / n)
    base = tracemalloc.get_traced_memory()[0]
    paper_update(p0, paper_view_likelihood_grid(grid, camera, views[0], kernel, SIGMA_FRACTION))
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    rows.append(_row("numpy", kernel, grid, t, len(views), state_bytes_per_cell=8, peak_temp_bytes=int(peak)))


def _numba_row(
    rows: list[dict[str, Any]],
    grid: VoxelGrid,
    camera: Camera,
    views: list[View],
    kernel: str,
    repeats: int,
    meta: dict[str, Any],
) -> None:
    """The fused kernel's own state (float32, lazy normalisation); the reset to uniform is not timed."""
    from ..methods.paper.engine.dense import DenseHistogram

    h = DenseHistogram(grid, kernel=kernel)
    t, first = Timing(), []
    for r in range(repeats + 1):
        h.reset()
        c0, w0 = time.process_time(), time.perf_counter()
        h.update_views(camera, views[0])
        w1 = time.perf_counter()
        for v in views[1:]:
            h.update_views(camera, v)
        if r:  # the first run is the warm-up
            t.wall.append(time.perf_counter() - w0)
            t.cpu.append(time.process_time() - c0)
            first.append(w1 - w0)
    rows.append(
        _row(
            "numba",
            kernel,
            grid,
            t,
            len(views),
            state_bytes_per_cell=h.memory_bytes / grid.n_cells,
            first_view_ms=statistics.median(first) * 1e3,
            first_view_min_ms=min(first) * 1e3,
            numba_threads=meta.get("numba_threads"),
        )
    )


def _sparse_row(
    rows: list[dict[str, Any]], grid: VoxelGrid, camera: Camera, views: list[View], kernel: str, repeats: int
) -> None:
    """The coarse-to-fine path at the dense grid's resolution (root 16 cells up, threshold 1e-3)."""
    from ..methods.paper.engine.params import pack_views

    packed = pack_views(grid, camera, views, kernel, SIGMA_FRACTION)
    last: dict[str, Any] = {}
    t = time_call(partial(run_sparse, grid, packed, SPARSE_LEVELS, SPARSE_THRESHOLD, last), repeats)
    st = last["s"].stats
    rows.append(
        _row(
            "sparse",
            kernel,
            grid,
            t,
            len(views),
            threshold=SPARSE_THRESHOLD,
            active_cells=st["active_cells"],
            peak_bytes=st["peak_bytes"],
            complete=st["complete"],
            final_resolution_mm=st["final_resolution_m"] * 1e3,
        )
    )


def _torch_row(
    rows: list[dict[str, Any]], grid: VoxelGrid, camera: Camera, views: list[View], kernel: str, repeats: int, device: Any
) -> None:
    from ..methods.paper.engine.torch_backend import TorchDenseHistogram

    h = TorchDenseHistogram(grid, kernel=kernel, device=str(device))
    t = time_call(partial(run_torch, h, camera, views), 1 if device.type == "cpu" else repeats)
    rows.append(_row(f"torch-{device.type}", kernel, grid, t, len(views), state_bytes_per_cell=h.memory_bytes / grid.n_cells))


def run_speed(
    *,
    quick: bool = False,
    edges: tuple[int, ...] | None = None,
    kernels: tuple[str, ...] = ("square", "gaussian"),
    repeats: int | None = None,
    naive_cells: int | None = None,
    torch_device: str | None = None,
    sparse_refine_to: float = 0.001,
    scaling: bool = True,
    threads: int | None = None,
    methods: tuple[str, ...] = METHODS,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run the benchmark; returns a JSON-serialisable dict (``meta``, ``rows``, ``scaling``).

    Parameters
    ----------
    quick : bool, small grids and few repetitions (a few seconds; for tests)
    edges : cells per axis of the grids (default :data:`FULL_EDGES`, or :data:`QUICK_EDGES`)
    kernels : kernels to run
    repeats : timed repetitions (default 5, 2 with ``quick``; numpy and naive get fewer on big grids)
    naive_cells : cells timed in the naive loop (default 20000, 2000 with ``quick``)
    torch_device : torch device (default cuda when available, else cpu); torch runs only if importable
    sparse_refine_to : metres, effective resolution of the sparse path
    scaling : also run the scaling with views and boxes
    threads : most numba threads per kernel call (default: numba's, usually one per core; each call
        takes fewer where its work is small, see :mod:`monovisual3d.kernels.threads`)
    methods : which of :data:`METHODS` to run (torch only where importable)
    progress : callable(str), told what runs next
    """
    from ..kernels.threads import thread_limit

    with thread_limit(threads):
        return _run_speed(quick, edges, kernels, repeats, naive_cells, torch_device, sparse_refine_to, scaling, methods, progress)


def _run_speed(
    quick: bool,
    edges: tuple[int, ...] | None,
    kernels: tuple[str, ...],
    repeats: int | None,
    naive_cells: int | None,
    torch_device: str | None,
    sparse_refine_to: float,
    scaling: bool,
    methods: tuple[str, ...],
    progress: Callable[[str], None] | None,
) -> dict[str, Any]:
    """The body of :func:`run_speed` (inside its thread limit)."""
    say = progress or (lambda s: None)
    edges = tuple(edges or (QUICK_EDGES if quick else FULL_EDGES))
    repeats = repeats or (2 if quick else 5)
    naive_cells = naive_cells or (2000 if quick else 20000)
    camera, views = bench_scene()
    meta = machine_metadata()
    meta["repeats"] = repeats
    torch_dev = _torch_device(torch_device, methods, meta)
    run = _Run(camera, views, kernels, methods, repeats, naive_cells, quick, meta, torch_dev, np.random.default_rng(0), say)
    rows: list[dict[str, Any]] = []

    for edge in edges:
        rows += _grid_rows(f"{edge}^3", paper_grid(views, edge), run)

    sparse_fine = sparse_fine_rows(camera, views, kernels if "sparse" in methods else (), sparse_refine_to, repeats, quick, say)

    scaling_rows: dict[str, Any] = {}
    if scaling:
        say("scaling")
        scaling_rows = update_scaling(edges[min(1, len(edges) - 1)], repeats, quick)
    say("end-to-end localize, idle and with a busy-loop process on one core")
    if quick:  # seconds: no numpy reference end to end, the comparison on a 2 cm grid
        e2e = end_to_end(1, configs={k: v for k, v in END_TO_END.items() if v.get("backend") != "numpy"})
    else:
        e2e = end_to_end(max(3, repeats))
    say("paper method, default settings vs the numpy reference")
    paper = paper_default_vs_numpy(repeats=1 if quick else max(3, repeats), resolution=0.02 if quick else 0.01)
    return {
        "meta": meta,
        "rows": rows,
        "sparse_fine": sparse_fine,
        "scaling": scaling_rows,
        "end_to_end": e2e,
        "paper_default_vs_numpy": paper,
    }


@dataclass(frozen=True)
class _Run:
    """What every grid of one :func:`run_speed` shares: the scene, the choices, the machine, the progress callback."""

    camera: Camera
    views: list[View]
    kernels: tuple[str, ...]
    methods: tuple[str, ...]
    repeats: int
    naive_cells: int
    quick: bool
    meta: dict[str, Any]
    torch_dev: Any
    rng: np.random.Generator  # one generator for every grid: the naive loop's cell subsamples
    say: Callable[[str], None]


def _grid_rows(name: str, grid: VoxelGrid, run: _Run) -> list[dict[str, Any]]:
    """The headline table's rows for one grid (``name`` in the progress lines): every chosen method and kernel."""
    camera, views, methods, repeats, say, torch_dev = run.camera, run.views, run.methods, run.repeats, run.say, run.torch_dev
    rows: list[dict[str, Any]] = []
    n_v = len(views)
    big = grid.n_cells > BIG_GRID_CELLS
    for kernel in run.kernels:
        tag = f"{name} {kernel}"
        if "naive-python" in methods:
            say(f"naive {tag}")
            _naive_row(rows, grid, camera, views, kernel, run.rng, run.naive_cells, big or run.quick)
        if "numpy" in methods:
            say(f"numpy {tag}")
            _numpy_row(rows, grid, camera, views, kernel, repeats, big)
        if "numba" in methods:
            say(f"numba {tag}")
            _numba_row(rows, grid, camera, views, kernel, repeats, run.meta)
        if "numba-filter" in methods:
            say(f"numba-filter {tag}")
            tq = time_call(partial(run_filter_path, grid, camera, views, kernel), repeats)
            rows.append(_row("numba-filter", kernel, grid, tq, n_v, state_bytes_per_cell=4))
        if "sparse" in methods:
            say(f"sparse {tag}")
            _sparse_row(rows, grid, camera, views, kernel, repeats)
        if "torch" in methods and torch_dev is not None and not (big and torch_dev.type == "cpu"):
            say(f"torch-{torch_dev.type} {tag}")
            _torch_row(rows, grid, camera, views, kernel, repeats, torch_dev)
    return rows


def _torch_device(torch_device: str | None, methods: tuple[str, ...], meta: dict[str, Any]) -> Any:
    """The torch device to time on, or None where torch is not importable (then noted in ``meta["skipped"]``)."""
    torch_dev = None
    try:
        from ..methods.paper.engine.torch_backend import resolve_device

        torch_dev = resolve_device(torch_device)
    except ImportError:
        if "torch" in methods:
            meta["skipped"] = ["torch: not importable, no torch rows (install the [gpu] extra to time it)"]
    return torch_dev


def format_table(result: dict[str, Any]) -> list[list[str]]:
    """Rows of the headline table: method, kernel, cells, per-view ms (median [min-max]), CPU ms, cells/s, x naive, bytes/cell."""
    naive = {(r["kernel"], r["cells"]): r["per_view_ms"]["median"] for r in result["rows"] if r["method"] == "naive-python"}
    table = []
    for r in result["rows"]:
        pv = r["per_view_ms"]
        speedup = naive.get((r["kernel"], r["cells"]), math.nan) / pv["median"] if pv["median"] > 0 else math.inf
        extra = ""
        if r["method"] == "numba":
            extra = f"first view {r['first_view_ms']:.2f} ms"
        elif r["method"] == "sparse":
            extra = f"{r['active_cells']:,} active, {r['peak_bytes'] / 2**20:.0f} MiB peak"
        elif r["method"] == "numpy":
            extra = f"{r['peak_temp_bytes'] / 2**20:.0f} MiB temporaries"
        table.append(
            [
                r["method"],
                r["kernel"],
                f"{r['cells'] / 1e6:.2f} M",
                f"{pv['median']:.2f} [{pv['min']:.2f}-{pv['max']:.2f}]",
                f"{pv['cpu_median']:.2f}",
                f"{r['cells_per_s'] / 1e6:,.0f} M",
                f"{speedup:,.0f}x" if math.isfinite(speedup) else "-",
                f"{r['state_bytes_per_cell']:.1f}" if "state_bytes_per_cell" in r else "-",
                extra,
            ]
        )
    return table


def format_markdown(result: dict[str, Any]) -> str:
    """The headline table and the sparse and scaling results as Markdown (for the README)."""
    meta = result["meta"]
    lines = [
        f"Machine: {meta['cpu']}, {meta['cores']} cores ({meta.get('numba_threads')} numba threads), "
        f"numpy {meta['numpy']}, numba {meta.get('numba')}, torch {meta.get('torch')}, load average {meta.get('load_average_1m', 0):.1f}",
        "",
        "| method | kernel | cells | ms/view median [min-max] | CPU ms | cells/s | vs naive | bytes/cell | notes |",
        "|---|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    lines += ["| " + " | ".join(r) + " |" for r in format_table(result)]
    if result.get("sparse_fine"):
        lines += [
            "",
            "| sparse | effective resolution | virtual cells | ms/view | active cells | peak MiB | reached |",
            "|---|---:|---:|---:|---:|---:|---:|",
        ]
        for r in result["sparse_fine"]:
            lines.append(
                f"| {r['kernel']} | {r['refine_to_mm']:g} mm | {r['virtual_cells'] / 1e9:.2f} G | {r['per_view_ms']['median']:.1f} "
                f"| {r['active_cells']:,} | {r['peak_bytes'] / 2**20:.0f} | {1e3 * r['final_resolution_m']:g} mm |"
            )
    sc = result.get("scaling") or {}
    if sc:
        lines += ["", "| views per update | sequential ms | one pass ms |", "|---:|---:|---:|"]
        lines += [
            f"| {r['views']} | {r['sequential_ms']['median']:.1f} | {r['one_pass_ms']['median']:.1f} |" for r in sc["views"]
        ]
        lines += ["", "| boxes per view | ms/view |", "|---:|---:|"]
        lines += [f"| {r['boxes']} | {r['per_view_ms']['median']:.2f} |" for r in sc["boxes"]]
    if result.get("end_to_end"):
        lines += ["", *format_end_to_end(result["end_to_end"])]
    p = result.get("paper_default_vs_numpy")
    if p:
        lines += [
            "",
            f"| paper method, {100 * p['resolution_m']:g} cm, 2R cube | cells | default ms median [min-max] "
            "| numpy reference ms | speed-up |",
            "|---|---:|---:|---:|---:|",
            f"| default ({p['default_backend']}) vs numpy reference, same run | {p['cells'] / 1e6:.2f} M "
            f"| {ms(p['default_s'])} | {ms(p['numpy_s'])} | {p['speedup']:.1f}x |",
        ]
    return "\n".join(lines)
