"""Whole ``localize`` calls on the paper's scene, idle and with one busy core; the paper method against its numpy reference."""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from .timing import Timing, busy_core, time_call

#: The load conditions of the end-to-end rows: none, and one busy-loop process (a robot's computer is never idle).
LOADS = ("idle", "busy one core")
#: End-to-end configurations: name -> localize options.
END_TO_END: dict[str, dict[str, Any]] = {
    "bayes (default)": {"method": "bayes"},
    "bayes, 2 cm scored grid": {"method": "bayes", "resolution": 0.02},
    "paper (default settings: gaussian, 1 cm, compiled)": {"method": "paper"},
    "paper, square, 1 cm, numba": {"method": "paper", "kernel": "square", "resolution": 0.01, "backend": "numba"},
    "paper, gaussian, 1 cm, numpy reference": {"method": "paper", "kernel": "gaussian", "resolution": 0.01, "backend": "numpy"},
}


def paper_session() -> Any:
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

    session = paper_session()
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

    session = paper_session()
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


def ms(s: dict[str, float]) -> str:
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
        cells = [ms(by[(config, ld)]["seconds"]) if (config, ld) in by else "-" for ld in loads]
        lines.append(f"| {config} | " + " | ".join(cells) + " |")
    return lines
