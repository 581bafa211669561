"""Throughput of ``batch`` on simulated paper-scene sessions, against ``localize`` in a loop.

Rows: sessions per second in-process (a plain loop of ``load_session`` +
``localize``, numba, OpenMP and BLAS limited to one thread like each worker) and through
:func:`monovisual3d.batch.run` with 1, 2, ... local worker processes (one
thread each). Derived: the speed-up of N workers over 1 and the overhead per
session of the 1-worker batch over the loop, the median over repeats of
``(wall_1w - wall_loop) / n`` with the loop timed right before each batch (reading, hashing, sending, evaluating against
``truth.json``, writing the parts and tables), in wall-clock time and in CPU
time summed over all processes (this one, which holds the scheduler, and the
workers): on a shared machine the CPU figure is the steadier. Cluster start-up and the first
(kernel-loading) call of each worker are timed apart and excluded.
"""

from __future__ import annotations

import json
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .._extras import require

#: The paper's noisy experiment: box noise 5 % of the box size, 2 % of the detections missed.
PAPER_NOISE = {"box_sigma": 0.05, "drop_probability": 0.02}


def simulate_sessions(folder: Path, n: int, progress: Callable[[str], None] | None = None) -> list[Path]:
    """``n`` paper-scene sessions (seeds 0..n-1, paper noise) in ``folder/sNNNNN``; existing ones are kept."""
    from ..sim.noise import NoiseModel
    from ..sim.scenes import paper_scene
    from ..sim.simulate import write_simulation

    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for seed in range(n):
        d = folder / f"s{seed:05d}"
        if not (d / "session.json").is_file() or not (d / "truth.json").is_file():
            write_simulation(d, paper_scene(), noise=NoiseModel(**PAPER_NOISE), rng=seed, images=False)
        paths.append(d / "session.json")
        if progress is not None and (seed + 1) % 200 == 0:
            progress(f"simulated {seed + 1}/{n} sessions")
    return paths


def _cpu_s() -> float:
    """CPU seconds (user + system) of this process and all its descendants (the local cluster's workers)."""
    import psutil

    me = psutil.Process()
    total = sum(me.cpu_times()[:2])
    for child in me.children(recursive=True):
        try:
            total += sum(child.cpu_times()[:2])
        except psutil.Error:  # pragma: no cover - a process that just ended
            pass
    return total


def _loop(paths: list[Path], method: str, options: dict[str, Any]) -> float:
    """Seconds for ``load_session`` + ``localize`` of every path, in this process."""
    from ..api import localize
    from ..session.load import load_session

    t0 = time.perf_counter()
    for p in paths:
        localize(load_session(p), method=method, **options)
    return time.perf_counter() - t0


def _warm(method: str, options: dict[str, Any]) -> None:
    """Load the compiled kernels of this process: one localisation of the built-in example."""
    from ..api import localize
    from ..examples import example_session_path

    localize(example_session_path(), method=method, **options)


def run_bench_batch(
    n_sessions: int = 1000,
    worker_counts: tuple[int, ...] = (1, 2),
    method: str = "paper",
    options: dict[str, Any] | None = None,
    data: Path | None = None,
    repeats: int = 1,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run the benchmark; returns a JSON-serialisable dict (``meta``, ``loop``, ``batch``, ``derived``).

    The in-process loop is timed right before each 1-worker batch (same
    repeat, same machine state), so the overhead is the median of paired
    differences and slow drifts of a shared machine cancel.
    """
    require("dask", "dask")
    import dask

    from .timing import machine_metadata

    options = dict(options or {})
    say = progress or (lambda msg: None)
    tmp = tempfile.TemporaryDirectory(prefix="mv3d-bench-batch-")
    data = Path(data) if data is not None else Path(tmp.name) / "sessions"
    paths = simulate_sessions(data, n_sessions, say)
    meta = machine_metadata()
    meta.update(n_sessions=n_sessions, method=method, options=options, repeats=repeats, dask=dask.__version__)
    loop: dict[str, list[float]] = {"wall_s": [], "cpu_s": []}
    batch = []
    for w in worker_counts:
        # the loop is timed once per repeat, beside the 1-worker batch (or the first worker count without one)
        with_loop = w == 1 or (1 not in worker_counts and w == worker_counts[0])
        batch.append(_bench_workers(paths, w, method, options, repeats, say, loop if with_loop else None))
    out: dict[str, Any] = {"meta": meta, "loop": _loop_entry(loop, n_sessions), "batch": batch}
    out["derived"] = _derived(out["loop"], out["batch"], n_sessions)
    tmp.cleanup()
    return json.loads(json.dumps(out, default=float))


def _time_loop(paths: list[Path], method: str, options: dict[str, Any]) -> tuple[float, float]:
    """Wall and CPU seconds of the in-process loop over ``paths`` on one thread (numba, OpenMP, BLAS), like a worker."""
    import numba
    from threadpoolctl import threadpool_limits

    threads = numba.get_num_threads()
    numba.set_num_threads(1)  # like each worker process (NUMBA_NUM_THREADS=1, OMP/BLAS 1 thread)
    try:
        with threadpool_limits(1):
            _warm(method, options)
            c0 = time.process_time()
            wall = _loop(paths, method, options)
            return wall, time.process_time() - c0
    finally:
        numba.set_num_threads(threads)


def _loop_entry(loop: dict[str, list[float]], n_sessions: int) -> dict[str, Any]:
    """The ``loop`` entry of the result from its timed runs."""
    loop_wall = statistics.median(loop["wall_s"])
    return {
        "wall_s": loop["wall_s"],
        "per_session_ms": 1000 * loop_wall / n_sessions,
        "sessions_per_s": n_sessions / loop_wall,
        "cpu_per_session_ms": 1000 * statistics.median(loop["cpu_s"]) / n_sessions,
    }


def _bench_workers(
    paths: list[Path],
    w: int,
    method: str,
    options: dict[str, Any],
    repeats: int,
    say: Callable[[str], None],
    loop: dict[str, list[float]] | None = None,
) -> dict[str, Any]:
    """Time :func:`monovisual3d.batch.run` on a local cluster of ``w`` workers; one row of the ``batch`` entry.

    With ``loop``, the in-process loop is timed before each repeat and appended to it.
    """
    from ..batch import run
    from ..batch.run import dask_client

    n_sessions = len(paths)
    t0 = time.perf_counter()
    with dask_client(w) as client:
        client.run(_warm, method, options)
        startup = time.perf_counter() - t0
        walls, cpus = [], []
        for r in range(repeats):
            if loop is not None:
                say(f"in-process loop over {n_sessions} sessions ({r + 1}/{repeats})")
                wall, cpu = _time_loop(paths, method, options)
                loop["wall_s"].append(wall)
                loop["cpu_s"].append(cpu)
                say(f"  loop: {wall:.1f} s wall, {cpu:.1f} CPU s")
            say(f"batch of {n_sessions} sessions on {w} worker(s) ({r + 1}/{repeats})")
            with tempfile.TemporaryDirectory(prefix="mv3d-bench-batch-out-") as out_dir:
                t1, c1 = time.perf_counter(), _cpu_s()
                tables = run(paths, out_dir, client=client, method=method, **options)
                walls.append(time.perf_counter() - t1)
                cpus.append(_cpu_s() - c1)
            say(f"  {w} worker(s): {walls[-1]:.1f} s wall, {cpus[-1]:.1f} CPU s")
            n_ok = int((tables.sessions["status"] == "ok").sum())
            if n_ok != n_sessions:
                raise RuntimeError(
                    f"bench batch: {n_sessions - n_ok} sessions failed: {tables.sessions['error'].dropna().iloc[0]}"
                )
    wall = statistics.median(walls)
    return {
        "workers": w,
        "wall_s": walls,
        "sessions_per_s": n_sessions / wall,
        "startup_s": startup,
        "per_session_ms": 1000 * wall / n_sessions,
        "cpu_s": cpus,
        "cpu_per_session_ms": 1000 * statistics.median(cpus) / n_sessions,
    }


def _derived(loop: dict[str, Any], batch: list[dict[str, Any]], n_sessions: int) -> dict[str, Any]:
    """Dask overhead per session (1 worker minus loop, median of the paired repeats) and the speed-up of each
    worker count over 1 worker."""
    rows = {r["workers"]: r for r in batch}
    derived: dict[str, Any] = {}
    if 1 in rows:
        one = rows[1]
        paired = [1000 * (b - a) / n_sessions for a, b in zip(loop["wall_s"], one["wall_s"])]
        derived["overhead_per_session_ms"] = statistics.median(paired)
        derived["overhead_per_session_ms_runs"] = paired
        derived["cpu_overhead_per_session_ms"] = one["cpu_per_session_ms"] - loop["cpu_per_session_ms"]
        for w, r in rows.items():
            if w != 1:
                derived[f"speedup_{w}w_over_1w"] = r["sessions_per_s"] / one["sessions_per_s"]
    return derived


def format_rows(result: dict[str, Any]) -> list[str]:
    """The benchmark as text lines (one row per configuration, then the derived numbers)."""
    m = result["meta"]
    lines = [
        f"{m['n_sessions']} paper-scene sessions, method {m['method']} {json.dumps(m['options'])}, "
        f"{m.get('cores')} cores, load {m.get('load_average_1m', float('nan')):.1f} (median of {m['repeats']})",
        f"in-process loop (1 thread): {result['loop']['sessions_per_s']:.2f} sessions/s, {result['loop']['per_session_ms']:.1f} ms/session, "
        f"{result['loop']['cpu_per_session_ms']:.1f} CPU ms/session",
    ]
    for r in result["batch"]:
        lines.append(
            f"batch, {r['workers']} worker(s): {r['sessions_per_s']:.2f} sessions/s, {r['per_session_ms']:.1f} ms/session, "
            f"{r['cpu_per_session_ms']:.1f} CPU ms/session (all processes) "
            f"(cluster start-up + warm-up {r['startup_s']:.1f} s, not counted)"
        )
    for k, v in result["derived"].items():
        if isinstance(v, list):
            lines.append(f"{k}: {', '.join(f'{x:.2f}' for x in v)}")
        else:
            lines.append(f"{k}: {v:.2f}")
    return lines
