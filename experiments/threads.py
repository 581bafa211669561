"""Where a second numba thread starts to pay off: per-call time against work, 1 thread vs all, idle and busy.

Run with ``python experiments/threads.py [--repeats 15] [--output threads.json]``.

Two kernels, each at growing sizes: the ``bayes`` hypothesis scoring (``score_hypotheses`` on the
paper scene's views, N centres x 16 radii) and the dense update of the paper method
(``paper_update_fused``, n**3 cells, three views). Each size is timed with one thread and with
numba's full pool (the work threshold is set to 1 for the timing, so that
:func:`monovisual3d.kernels.threads.thread_limit` alone fixes the count), interleaved call by call so that both
see the same load, idle and with a busy-loop process on one core. The work estimate of each call
(what :func:`~monovisual3d.kernels.threads.threads_for` sees) is printed beside it:
:data:`~monovisual3d.kernels.threads.MIN_WORK_PER_THREAD` is chosen where "all" stops losing.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numba
import numpy as np

from monovisual3d.bench.timing import busy_core, machine_metadata
from monovisual3d.bench.update_cases import bench_scene, paper_grid
from monovisual3d.frames import invert_transform
from monovisual3d.kernels import threads
from monovisual3d.kernels.threads import thread_limit, threads_for
from monovisual3d.methods.bayes._kernels import score_hypotheses, score_work_ns
from monovisual3d.methods.bayes.sensor import SensorModel
from monovisual3d.methods.paper.engine.dense import NS_PER_CELL_VIEW, paper_update_fused


def _score_case(n: int):  # type: ignore[no-untyped-def]
    camera, views = bench_scene()
    rng = np.random.default_rng(0)
    centres = rng.uniform([-0.3, -0.3, 0.3], [0.3, 0.3, 0.9], (n, 3))
    centres = (views[0].T_base_optical[:3, :3] @ centres.T).T + views[0].T_base_optical[:3, 3]
    T = [invert_transform(v.T_base_optical) for v in views]
    boxes = [v.boxes_xyxy for v in views]
    avail = [np.ones(len(b), bool) for b in boxes]
    radii = np.linspace(0.02, 0.06, 16)
    work = n * len(radii) * score_work_ns(np.array([len(b) for b in boxes]))
    return work, lambda: score_hypotheses(camera, T, boxes, avail, centres, radii, SensorModel(), 0.005)


def _dense_case(edge: int):  # type: ignore[no-untyped-def]
    camera, views = bench_scene()
    grid = paper_grid(views, edge)
    prior = np.full(grid.n_cells, 1.0 / grid.n_cells, dtype=np.float32)
    work = NS_PER_CELL_VIEW * grid.n_cells * len(views)
    return work, lambda: paper_update_fused(prior, grid, camera, views)


def _time(fn, n_threads: int) -> float:  # type: ignore[no-untyped-def]
    saved = threads.MIN_WORK_PER_THREAD
    threads.MIN_WORK_PER_THREAD = 1  # every call gets exactly the limit
    try:
        with thread_limit(n_threads):
            t0 = time.perf_counter()
            fn()
            return time.perf_counter() - t0
    finally:
        threads.MIN_WORK_PER_THREAD = saved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--output", default=None)
    args = parser.parse_args()
    full = numba.config.NUMBA_NUM_THREADS
    cases = [("score", n, *_score_case(n)) for n in (100, 1000, 4000, 15000)]
    cases += [("dense", e, *_dense_case(e)) for e in (16, 32, 63, 126)]
    rows = []
    for load in ("idle", "busy one core"):
        with busy_core(load != "idle"):
            for kernel, size, work, fn in cases:
                fn()  # compile / warm
                one, many = [], []
                for _ in range(args.repeats):
                    one.append(_time(fn, 1))
                    many.append(_time(fn, full))
                row = {
                    "load": load,
                    "kernel": kernel,
                    "size": size,
                    "work_items": int(work),
                    "chosen_threads": threads_for(int(work)),
                    "one_thread_ms": 1e3 * statistics.median(one),
                    f"{full}_threads_ms": 1e3 * statistics.median(many),
                }
                rows.append(row)
                print(json.dumps(row), flush=True)
    if args.output:
        with open(args.output, "w") as fh:
            json.dump({"meta": machine_metadata(), "rows": rows}, fh, indent=2)


if __name__ == "__main__":
    main()
