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

import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
import tracemalloc
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np

from .. import __version__
from ..camera import Camera
from ..grid import VoxelGrid
from ..methods.paper.kernels import paper_cell_likelihood
from ..session import Detection, View

#: Grid edges (cells per axis) of the full benchmark: 63**3 = 0.25 M, 126**3 = 2 M, 252**3 = 16 M.
FULL_EDGES = (63, 126, 252)
#: Grid edges of --quick.
QUICK_EDGES = (32, 63)
#: Side of the paper's cube, metres (2 x reach 0.6 m).
CUBE_M = 1.2
#: Methods of the headline table, in order.
METHODS = ("naive-python", "numpy", "numba", "numba-filter", "sparse", "torch")


@dataclass
class Timing:
    """Wall and CPU times of repeated runs, seconds."""

    wall: list[float] = field(default_factory=list)
    cpu: list[float] = field(default_factory=list)

    def summary(self, scale: float = 1.0) -> dict[str, float]:
        """Median, min, max, IQR of the wall time and median CPU time, times ``scale`` (e.g. 1e3 for ms)."""
        w = sorted(self.wall)
        q = np.percentile(w, [25, 75]) if len(w) > 1 else [w[0], w[0]]
        return {
            "median": statistics.median(w) * scale,
            "min": w[0] * scale,
            "max": w[-1] * scale,
            "iqr": float(q[1] - q[0]) * scale,
            "cpu_median": statistics.median(self.cpu) * scale,
            "n": len(w),
        }


def time_call(fn: Callable[[], Any], repeats: int, warmup: int = 1) -> Timing:
    """Run ``fn`` ``warmup`` times untimed, then ``repeats`` times timed."""
    for _ in range(warmup):
        fn()
    t = Timing()
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        t.wall.append(time.perf_counter() - w0)
        t.cpu.append(time.process_time() - c0)
    return t


def machine_metadata() -> dict[str, Any]:
    """CPU model, cores, memory, library versions, load average."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:  # pragma: no cover - not Linux
        pass
    meta: dict[str, Any] = {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "monovisual3d": __version__,
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    try:
        with open("/proc/meminfo") as fh:
            meta["memory_gib"] = round(int(fh.readline().split()[1]) / 1024**2, 1)
    except OSError:  # pragma: no cover
        pass
    try:
        meta["load_average_1m"] = os.getloadavg()[0]
    except OSError:  # pragma: no cover
        pass
    try:
        import numba

        meta["numba"] = numba.__version__
        meta["numba_threads"] = numba.get_num_threads()
    except ImportError:  # pragma: no cover
        meta["numba"] = None
    try:
        import torch

        meta["torch"] = torch.__version__
        meta["cuda"] = torch.cuda.get_device_name(0) if torch.cuda.is_available() else None
    except ImportError:
        meta["torch"] = None
    return meta


def bench_scene(n_views: int = 3, n_boxes: int = 6, seed: int = 0) -> tuple[Camera, list[View]]:
    """The paper's scene and poses with exact boxes; more views/boxes for the scaling runs.

    Views beyond the paper's three look at the target from random points 0.5 m
    away (within 30 degrees of the first view's axis). Boxes beyond the six
    spheres' are copies of them shifted by up to 40 px (so that every box is
    like a fruit's); fewer boxes keep the first ``n_boxes``.
    """
    from ..frames import look_at
    from ..geometry.sphere import sphere_bbox
    from ..sim.scenes import default_camera, paper_scene
    from ..sim.viewpoints import DEFAULT_TARGET, paper_poses

    rng = np.random.default_rng(seed)
    camera = default_camera()
    scene = paper_scene()
    poses = list(paper_poses())
    target = np.asarray(DEFAULT_TARGET, dtype=float)
    axis = (target - poses[0][:3, 3]) / np.linalg.norm(target - poses[0][:3, 3])
    while len(poses) < n_views:
        d = axis + rng.normal(scale=0.3, size=3)
        d /= np.linalg.norm(d)
        poses.append(look_at(target - 0.5 * d, target))
    views = []
    for T in poses[:n_views]:
        boxes = sphere_bbox(camera, T, scene.centres, scene.radii)
        boxes = boxes[np.all(np.isfinite(boxes), axis=1)]
        extra = []
        while len(boxes) + len(extra) < n_boxes:
            b = boxes[len(extra) % len(boxes)] + np.repeat(rng.uniform(-40, 40, 2), 2)[[0, 2, 1, 3]]
            extra.append(np.clip(b, 0, [camera.width, camera.height] * 2))
        allb = np.concatenate([boxes, np.asarray(extra).reshape(-1, 4)])[:n_boxes]
        views.append(View(T, tuple(Detection(b) for b in allb)))
    return camera, views


def paper_grid(views: list[View], edge: int) -> VoxelGrid:
    """The paper's cube in front of the first view, ``edge**3`` cells."""
    return VoxelGrid.in_front_of_camera(views[0].T_base_optical, CUBE_M / edge, CUBE_M / 2, max_bytes=2**40)


def naive_update(
    prior: np.ndarray, grid: VoxelGrid, camera: Camera, view: View, kernel: str, sigma_fraction: float, cells: np.ndarray
) -> float:
    """Algorithm 1 as a per-cell pure-Python loop over ``cells`` (flat indices); returns the partial normaliser.

    Transform to the optical frame, pinhole projection with distortion, the
    mean of the box kernels, multiply by the prior: written well (scalars and
    ``math``, no numpy per cell), as a Python port of the paper would be.
    """
    from ..frames import invert_transform

    T = (invert_transform(view.T_base_optical) @ grid.T_base_grid).tolist()
    fx, fy, cx, cy = camera.fx, camera.fy, camera.cx, camera.cy
    model, d = camera.distortion_model, list(camera.distortion_coefficients) + [0.0] * 8
    boxes = view.boxes_xyxy.tolist()
    ni, nj, nk = grid.shape
    res = grid.resolution
    total = 0.0
    for c in cells.tolist():
        i, rem = divmod(c, nj * nk)
        j, k = divmod(rem, nk)
        gx, gy, gz = (i + 0.5) * res, (j + 0.5) * res, (k + 0.5) * res
        z = T[2][0] * gx + T[2][1] * gy + T[2][2] * gz + T[2][3]
        if z <= 0:
            continue
        x = (T[0][0] * gx + T[0][1] * gy + T[0][2] * gz + T[0][3]) / z
        y = (T[1][0] * gx + T[1][1] * gy + T[1][2] * gz + T[1][3]) / z
        if model in ("plumb_bob", "rational_polynomial"):
            r2 = x * x + y * y
            radial = 1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]))
            if model == "rational_polynomial":
                radial /= 1 + r2 * (d[5] + r2 * (d[6] + r2 * d[7]))
            x, y = (
                x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x),
                y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y,
            )
        u, v = fx * x + cx, fy * y + cy
        p = prior[c] * paper_cell_likelihood(u, v, boxes, kernel, sigma_fraction)
        prior[c] = p
        total += p
    return total


def _run_naive(grid: VoxelGrid, camera: Camera, views: list[View], kernel: str, cells: np.ndarray, prior: np.ndarray) -> None:
    for v in views:
        naive_update(prior, grid, camera, v, kernel, 0.5, cells)


def _run_numpy(grid: VoxelGrid, camera: Camera, views: list[View], kernel: str) -> None:
    from ..methods.paper.filter import paper_update, paper_view_likelihood_grid

    p: Any = np.full(grid.n_cells, 1.0 / grid.n_cells)
    for v in views:
        p = paper_update(p, paper_view_likelihood_grid(grid, camera, v, kernel, 0.5))


def _run_filter_path(grid: VoxelGrid, camera: Camera, views: list[View], kernel: str) -> None:
    from ..engine.dense import paper_update_fused

    p: Any = np.full(grid.n_cells, 1.0 / grid.n_cells, dtype=np.float32)
    for v in views:
        p = paper_update_fused(p, grid, camera, v, kernel, 0.5)


def _run_sparse(grid: VoxelGrid, packed: Any, levels: int, threshold: float, out: dict[str, Any]) -> None:
    from ..engine.sparse import refine

    out["s"] = refine(grid, packed, levels, threshold=threshold)


def _run_state(h: Any, camera: Camera, views: list[View], one_pass: bool) -> None:
    h.reset()
    if one_pass:
        h.update_views(camera, views)
    else:
        for v in views:
            h.update_views(camera, v)


def _run_torch(h: Any, camera: Camera, views: list[View]) -> None:
    h.values.fill_(1.0 / h.grid.n_cells)
    for v in views:
        h.update_views(camera, v)
    if h.device.type == "cuda":
        import torch

        torch.cuda.synchronize()


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
    rows: list[dict[str, Any]], grid: VoxelGrid, camera: Camera, views: list[View], kernel: str,
    rng: np.random.Generator, naive_cells: int, once: bool,
) -> None:  # fmt: skip
    """The per-cell Python loop on a random subsample of cells, extrapolated to the grid."""
    n = grid.n_cells
    cells = rng.choice(n, size=min(naive_cells, n), replace=False)
    prior = np.full(n, 1.0 / n)
    t = time_call(partial(_run_naive, grid, camera, views, kernel, cells, prior), 1 if once else 2, warmup=0)
    f = n / len(cells)
    t = Timing([w * f for w in t.wall], [c * f for c in t.cpu])
    rows.append(_row("naive-python", kernel, grid, t, len(views), extrapolated_from_cells=len(cells), state_bytes_per_cell=8))


def _numpy_row(
    rows: list[dict[str, Any]], grid: VoxelGrid, camera: Camera, views: list[View], kernel: str, repeats: int, big: bool
) -> None:
    """The numpy reference; its temporaries are measured with tracemalloc in a separate run."""
    from ..methods.paper.filter import paper_update, paper_view_likelihood_grid

    n = grid.n_cells
    t = time_call(partial(_run_numpy, grid, camera, views, kernel), 1 if big else repeats, warmup=0 if big else 1)
    tracemalloc.start()
    tracemalloc.reset_peak()
    p0 = np.full(n, 1.0 / n)
    base = tracemalloc.get_traced_memory()[0]
    paper_update(p0, paper_view_likelihood_grid(grid, camera, views[0], kernel, 0.5))
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
    from ..engine.dense import DenseHistogram

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
            "numba", kernel, grid, t, len(views), state_bytes_per_cell=h.memory_bytes / grid.n_cells,
            first_view_ms=statistics.median(first) * 1e3, first_view_min_ms=min(first) * 1e3,
            numba_threads=meta.get("numba_threads"),
        )
    )  # fmt: skip


def _sparse_row(
    rows: list[dict[str, Any]], grid: VoxelGrid, camera: Camera, views: list[View], kernel: str, repeats: int
) -> None:
    """The coarse-to-fine path at the dense grid's resolution (root 16 cells up, threshold 1e-3)."""
    from ..engine.params import pack_views

    packed = pack_views(grid, camera, views, kernel, 0.5)
    last: dict[str, Any] = {}
    t = time_call(partial(_run_sparse, grid, packed, 4, 1e-3, last), repeats)
    st = last["s"].stats
    rows.append(
        _row(
            "sparse", kernel, grid, t, len(views), threshold=1e-3, active_cells=st["active_cells"],
            peak_bytes=st["peak_bytes"], complete=st["complete"], final_resolution_mm=st["final_resolution_m"] * 1e3,
        )
    )  # fmt: skip


def _torch_row(
    rows: list[dict[str, Any]], grid: VoxelGrid, camera: Camera, views: list[View], kernel: str, repeats: int, device: Any
) -> None:
    from ..engine.torch_backend import TorchDenseHistogram

    h = TorchDenseHistogram(grid, kernel=kernel, device=str(device))
    t = time_call(partial(_run_torch, h, camera, views), 1 if device.type == "cpu" else repeats)
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
        takes fewer where its work is small, see :mod:`monovisual3d.engine.threads`)
    methods : which of :data:`METHODS` to run (torch only where importable)
    progress : callable(str), told what runs next
    """
    from ..engine.threads import thread_limit

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
    n_v = len(views)
    rows: list[dict[str, Any]] = []
    rng = np.random.default_rng(0)
    meta = machine_metadata()
    meta["repeats"] = repeats
    torch_dev = _torch_device(torch_device, methods, meta)

    for edge in edges:
        grid = paper_grid(views, edge)
        big = grid.n_cells > 4_000_000
        for kernel in kernels:
            tag = f"{edge}^3 {kernel}"
            if "naive-python" in methods:
                say(f"naive {tag}")
                _naive_row(rows, grid, camera, views, kernel, rng, naive_cells, big or quick)
            if "numpy" in methods:
                say(f"numpy {tag}")
                _numpy_row(rows, grid, camera, views, kernel, repeats, big)
            if "numba" in methods:
                say(f"numba {tag}")
                _numba_row(rows, grid, camera, views, kernel, repeats, meta)
            if "numba-filter" in methods:
                say(f"numba-filter {tag}")
                tq = time_call(partial(_run_filter_path, grid, camera, views, kernel), repeats)
                rows.append(_row("numba-filter", kernel, grid, tq, n_v, state_bytes_per_cell=4))
            if "sparse" in methods:
                say(f"sparse {tag}")
                _sparse_row(rows, grid, camera, views, kernel, repeats)
            if "torch" in methods and torch_dev is not None and not (big and torch_dev.type == "cpu"):
                say(f"torch-{torch_dev.type} {tag}")
                _torch_row(rows, grid, camera, views, kernel, repeats, torch_dev)

    sparse_fine = _sparse_fine_rows(camera, views, kernels if "sparse" in methods else (), sparse_refine_to, repeats, quick, say)

    scaling_rows: dict[str, Any] = {}
    if scaling:
        say("scaling")
        scaling_rows = _scaling(edges[min(1, len(edges) - 1)], repeats, quick)
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


def _torch_device(torch_device: str | None, methods: tuple[str, ...], meta: dict[str, Any]) -> Any:
    """The torch device to time on, or None where torch is not importable (then noted in ``meta["skipped"]``)."""
    torch_dev = None
    try:
        from ..engine.torch_backend import resolve_device

        torch_dev = resolve_device(torch_device)
    except ImportError:
        if "torch" in methods:
            meta["skipped"] = ["torch: not importable, no torch rows (install the [gpu] extra to time it)"]
    return torch_dev


def _sparse_fine_rows(
    camera: Camera,
    views: list[View],
    kernels: Iterable[str],
    sparse_refine_to: float,
    repeats: int,
    quick: bool,
    say: Callable[[str], None],
) -> list[dict[str, Any]]:
    """Sparse at ``sparse_refine_to`` effective resolution over the paper's cube, one row per kernel."""
    from ..engine.params import pack_views
    from ..engine.sparse import levels_between

    n_v = len(views)
    # sparse at 1 mm effective resolution over the same cube (no dense grid could hold it: 1.7 G cells)
    sparse_fine: list[dict[str, Any]] = []
    fine = VoxelGrid.in_front_of_camera(views[0].T_base_optical, sparse_refine_to, CUBE_M / 2, max_bytes=2**62)
    for kernel in kernels:
        say(f"sparse {sparse_refine_to * 1e3:g} mm {kernel}")
        packed = pack_views(fine, camera, views, kernel, 0.5)
        levels = levels_between(0.016, sparse_refine_to)
        last: dict[str, Any] = {}
        t = time_call(partial(_run_sparse, fine, packed, levels, 1e-3, last), 1 if quick else max(2, repeats // 2))
        st = last["s"].stats
        sparse_fine.append(
            {
                "kernel": kernel,
                "virtual_cells": fine.n_cells,
                "refine_to_mm": sparse_refine_to * 1e3,
                "root_mm": 16.0,
                "views": n_v,
                "total_ms": t.summary(1e3),
                "per_view_ms": t.summary(1e3 / n_v),
                "threshold": 1e-3,
                **{k: st[k] for k in ("active_cells", "peak_bytes", "complete", "final_resolution_m", "levels")},
            }
        )
    return sparse_fine


#: End-to-end configurations: name -> localize options.
END_TO_END: dict[str, dict[str, Any]] = {
    "bayes (default)": {"method": "bayes"},
    "bayes, 2 cm scored grid": {"method": "bayes", "resolution": 0.02},
    "paper (default settings: gaussian, 1 cm, compiled)": {"method": "paper"},
    "paper, square, 1 cm, numba": {"method": "paper", "kernel": "square", "resolution": 0.01, "backend": "numba"},
    "paper, gaussian, 1 cm, numpy reference": {"method": "paper", "kernel": "gaussian", "resolution": 0.01, "backend": "numpy"},
}
#: The load conditions of the end-to-end rows: none, and one busy-loop process (a robot's computer is never idle).
LOADS = ("idle", "busy one core")


@contextmanager
def busy_core(active: bool = True) -> Iterator[None]:
    """Run the block with a busy-loop Python process holding one core (nothing when ``active`` is False)."""
    if not active:
        yield
        return
    proc = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.2)  # let it start spinning
        yield
    finally:
        proc.kill()
        proc.wait()


def _paper_session() -> Any:
    from ..sim.scenes import paper_scene
    from ..sim.simulate import simulate

    session, _ = simulate(paper_scene(), rng=0)
    return session


def end_to_end(
    repeats: int = 5, loads: tuple[str, ...] = LOADS, configs: dict[str, dict[str, Any]] | None = None
) -> list[dict[str, Any]]:
    """Whole ``localize`` calls on the paper's six-sphere scene seen from its three views (simulated, exact boxes).

    Every configuration of ``configs`` (default :data:`END_TO_END`) is timed under each of ``loads``: idle,
    and with a busy-loop process on one core (started and stopped here). One untimed
    warm-up call per configuration loads numba's cached kernels (a robot process pays
    that once); the timed calls include everything else: grid, search, scoring,
    extraction, refinement / k-means. The session has no workspace, so the paper
    method's grid is its 2R cube (reach 0.6 m: 1.2 m side, 1.7 M cells at 1 cm).
    """
    from ..api import localize

    session = _paper_session()
    out = []
    for load in loads:
        with busy_core(load != "idle"):
            for name, opts in (configs or END_TO_END).items():
                t = time_call(lambda opts=opts: localize(session, **opts), repeats=repeats, warmup=1)
                out.append({"config": name, "options": opts, "load": load, "seconds": t.summary(1.0)})
    return out


def paper_default_vs_numpy(repeats: int = 3, resolution: float = 0.01) -> dict[str, Any]:
    """The paper method on its 2R cube (1 cm: 1.7 M cells), default settings against the numpy reference, same run.

    Alternates the two (default, reference, default, ...) so that both see the same load;
    returns their medians, the speed-up and the largest distance between their estimates.
    """
    from ..api import localize
    from ..grid import VoxelGrid

    session = _paper_session()
    grid = VoxelGrid.in_front_of_camera(session.views[0].T_base_optical, resolution, 0.6)
    fast, ref = Timing(), Timing()
    res_fast = localize(session, method="paper", resolution=resolution)  # warm-up
    res_ref = localize(session, method="paper", resolution=resolution, backend="numpy")
    for _ in range(repeats):
        for timing, opts in ((fast, {}), (ref, {"backend": "numpy"})):
            c0, w0 = time.process_time(), time.perf_counter()
            localize(session, method="paper", resolution=resolution, **opts)
            timing.wall.append(time.perf_counter() - w0)
            timing.cpu.append(time.process_time() - c0)
    a = np.array([o.position for o in res_fast.objects]).reshape(-1, 3)
    b = np.array([o.position for o in res_ref.objects]).reshape(-1, 3)
    diff = math.nan
    if len(a) and len(b):  # largest distance from an estimate to the nearest estimate of the other run
        d = np.linalg.norm(a[:, None] - b[None], axis=2)
        diff = float(max(d.min(1).max(), d.min(0).max()))
    f, r = fast.summary(1.0), ref.summary(1.0)
    return {
        "config": f"paper method {resolution * 100:g} cm on the paper 2R cube, default settings vs numpy reference, same run",
        "resolution_m": resolution,
        "cells": grid.n_cells,
        "default_backend": res_fast.config.get("backend"),
        "default_s": f,
        "numpy_s": r,
        "speedup": r["median"] / f["median"],
        "objects": [len(a), len(b)],
        "max_position_difference_m": diff,
    }


def _scaling(edge: int, repeats: int, quick: bool) -> dict[str, Any]:
    """Fused numba (Gaussian): time per update against views per pass and boxes per view."""
    from ..engine.dense import DenseHistogram

    out: dict[str, Any] = {"edge": edge, "kernel": "gaussian", "views": [], "boxes": []}
    for nv in (1, 3, 9) if not quick else (1, 3):
        camera, views = bench_scene(n_views=nv)
        grid = paper_grid(views, edge)

        h = DenseHistogram(grid)
        ts = time_call(partial(_run_state, h, camera, views, False), repeats)
        tb = time_call(partial(_run_state, h, camera, views, True), repeats)
        out["views"].append(
            {"views": nv, "cells": grid.n_cells, "sequential_ms": ts.summary(1e3), "one_pass_ms": tb.summary(1e3)}
        )
    for nb in (1, 6, 24) if not quick else (1, 6):
        camera, views = bench_scene(n_boxes=nb)
        grid = paper_grid(views, edge)

        t = time_call(partial(_run_state, DenseHistogram(grid), camera, views, False), repeats)
        out["boxes"].append({"boxes": nb, "cells": grid.n_cells, "per_view_ms": t.summary(1e3 / len(views))})
    return out


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


def write_json(result: dict[str, Any], path: str) -> None:
    with open(path, "w") as fh:
        json.dump(result, fh, indent=2, default=float)
        fh.write("\n")


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
            f"| {_ms(p['default_s'])} | {_ms(p['numpy_s'])} | {p['speedup']:.1f}x |",
        ]
    return "\n".join(lines)


def _ms(s: dict[str, float]) -> str:
    return f"{1e3 * s['median']:.0f} [{1e3 * s['min']:.0f}-{1e3 * s['max']:.0f}]"


def format_end_to_end(rows: list[dict[str, Any]]) -> list[str]:
    """Markdown table of :func:`end_to_end`: one line per configuration, one column per load."""
    loads = list(dict.fromkeys(r.get("load", "idle") for r in rows))
    by = {(r["config"], r.get("load", "idle")): r for r in rows}
    lines = [
        "| end-to-end localize, six fruit, three views | " + " | ".join(f"{ld}: ms median [min-max]" for ld in loads) + " |",
        "|---|" + "---:|" * len(loads),
    ]
    for config in dict.fromkeys(r["config"] for r in rows):
        cells = [_ms(by[(config, ld)]["seconds"]) if (config, ld) in by else "-" for ld in loads]
        lines.append(f"| {config} | " + " | ".join(cells) + " |")
    return lines
