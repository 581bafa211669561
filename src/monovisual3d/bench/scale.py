"""Scale benchmark: the default method on plant rows of growing density (``monovisual3d bench scale``).

The scene is :func:`monovisual3d.sim.row.row_scene`: fruit of 20-40 mm radius spread
over a 1.2 x 0.7 x 0.25 m row, seen by the wide 1280 x 720 camera
(:func:`~monovisual3d.sim.row.row_camera`) from N views along the row at 0.8 m
(:func:`~monovisual3d.sim.viewpoints.row_poses`), boxes with 3 % noise (std as a
fraction of the box size), the row's box stated as the workspace. Two sweeps:
the number of fruit at :data:`SWEEP_VIEWS` views, and the number of views at
:data:`SWEEP_FRUIT` fruit.

Per case: the median over seeds of the median over ``repeats`` timed calls of
``timing_s.total`` (the method's own time, without loading the session) and of
the process's CPU time over the call (all threads: on a shared machine it shows the
work when the wall time shows the queue), the
pooled mean error of the matched fruit (mm), recall and precision
(:func:`monovisual3d.metrics.evaluate`), and the boxes per view. The growth
factor is time(largest fruit count <= 96) / time(smallest), the target being
at most 12 for 12 -> 96 fruit (8 times the fruit). Each case runs idle and, with
``busy``, again with a busy-loop process on one core.
"""

from __future__ import annotations

import json
import statistics
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..api import localize
from ..errors import InputError
from ..metrics import evaluate
from ..session import Workspace
from ..sim.noise import NoiseModel
from ..sim.row import row_camera, row_scene
from ..sim.simulate import simulate
from ..sim.viewpoints import row_poses
from .timing import busy_core, machine_metadata

#: Fruit counts of the fruit sweep and its number of views.
FRUIT_COUNTS, SWEEP_VIEWS = (12, 24, 48, 96, 192), 5
#: View counts of the view sweep and its number of fruit.
VIEW_COUNTS, SWEEP_FRUIT = (3, 5, 8), 48
#: Box noise of the scenes (std as a fraction of the box size).
BOX_NOISE = 0.03
#: The issue's targets: seconds for 96 fruit x 5 views, growth 12 -> 96 fruit, recall, dense/sparse error ratio.
TARGET_S_96, TARGET_GROWTH, TARGET_RECALL, TARGET_ERROR_RATIO = 2.0, 12.0, 0.98, 1.2
#: Options of the benchmarked method.
OPTIONS: dict[str, Any] = {"method": "bayes", "use_masks": False}


def row_session(n_fruit: int, n_views: int, seed: int):  # noqa: ANN201 - (Session, Scene)
    """The benchmark's row session of ``n_fruit`` fruit from ``n_views`` views (seeded) and its scene."""
    scene = row_scene(n_fruit, seed)
    ws = scene.metadata["workspace"]
    session, _ = simulate(
        scene,
        row_camera(),
        row_poses(n_views),
        noise=NoiseModel(box_sigma=BOX_NOISE),
        rng=seed,
        workspace=Workspace(np.asarray(ws["min"], dtype=float), np.asarray(ws["max"], dtype=float)),
    )
    return session, scene


def run_cases(
    cases: Sequence[tuple[int, int]], seeds: Sequence[int], repeats: int, say: Callable[[str], None]
) -> list[dict[str, Any]]:
    """The (fruit, views) ``cases`` over ``seeds``: time, errors, recall, precision, boxes per view, one dict per case.

    Each case and seed is timed ``repeats`` times, in rounds: every round times every case once per seed, so that a
    slow spell of a shared machine falls on all cases alike (the growth factor divides the times of two of them).
    """
    sessions = [[row_session(n, v, seed) for seed in seeds] for n, v in cases]
    times = [[[] for _ in seeds] for _ in cases]
    cpu = [[[] for _ in seeds] for _ in cases]
    last: list[list[Any]] = [[None] * len(seeds) for _ in cases]
    for r in range(repeats):
        for c, (n, v) in enumerate(cases):
            say(f"{n} fruit x {v} views" + (f" (round {r + 1} of {repeats})" if repeats > 1 else ""))
            for k, (session, _) in enumerate(sessions[c]):
                c0 = time.process_time()
                last[c][k] = localize(session, **OPTIONS)
                cpu[c][k].append(time.process_time() - c0)
                times[c][k].append(float(last[c][k].timing_s["total"]))
    rows = []
    for c, (n, v) in enumerate(cases):
        per_seed = [statistics.median(t) for t in times[c]]
        errors, n_truth, tp, n_est = 0.0, 0, 0, 0
        for (_, scene), res in zip(sessions[c], last[c]):
            est = np.array([o.position for o in res.objects]).reshape(-1, 3)
            m = evaluate(est, scene.centres, truth_radii=scene.radii)
            errors += m.euclidean_mean * m.true_positives if m.true_positives else 0.0
            n_truth, tp, n_est = n_truth + m.n_truth, tp + m.true_positives, n_est + m.n_estimates
        rows.append(
            {
                "fruit": n,
                "views": v,
                "boxes_per_view": statistics.mean(np.mean([len(vw.detections) for vw in s.views]) for s, _ in sessions[c]),
                "time_s": statistics.median(per_seed),
                "time_s_per_seed": per_seed,
                "cpu_s": statistics.median(statistics.median(t) for t in cpu[c]),
                "mean_mm": 1e3 * errors / tp if tp else None,
                "recall": tp / n_truth if n_truth else None,
                "precision": tp / n_est if n_est else None,
            }
        )
    return rows


def run_scale(
    fruit: Sequence[int] = FRUIT_COUNTS,
    views: Sequence[int] = VIEW_COUNTS,
    seeds: Sequence[int] = (0, 1, 2),
    repeats: int = 1,
    busy: bool = True,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Both sweeps, idle and (with ``busy``) with a busy-loop process on one core.

    Returns ``{"meta": machine metadata and the settings, "rows": [case dicts with "sweep" and "load"],
    "growth": {load: time(largest <= 96 fruit) / time(smallest)}}``.
    """
    if not fruit or not views or not seeds or repeats < 1:
        raise InputError("bench scale: expected at least one fruit count, view count and seed, and repeats >= 1")
    if any(int(n) < 1 for n in fruit) or any(int(v) < 2 for v in views):
        raise InputError("bench scale: fruit counts must be >= 1 and view counts >= 2")
    say = progress or (lambda _msg: None)
    warm, _ = row_session(6, 3, 0)
    localize(warm, **OPTIONS)  # loads numba's cached kernels outside the timing
    meta = {
        **machine_metadata(),
        "seeds": list(seeds),
        "repeats": repeats,
        "box_noise": BOX_NOISE,
        "camera": "1280x720, 90 deg",
        "row_m": "1.2 x 0.7 x 0.25",
        "distance_m": 0.8,
        "options": OPTIONS,
    }
    cases = [("fruit", int(n), SWEEP_VIEWS) for n in fruit] + [("views", SWEEP_FRUIT, int(v)) for v in views]
    rows: list[dict[str, Any]] = []
    for load in ("idle", "busy one core") if busy else ("idle",):
        with busy_core(load != "idle"):
            measured = run_cases([(n, v) for _, n, v in cases], seeds, repeats, lambda msg, ld=load: say(f"{ld}: {msg}"))
        rows += [{"sweep": sweep, "load": load, **row} for (sweep, _, _), row in zip(cases, measured)]
    return {"meta": meta, "rows": rows, "growth": growth(rows)}


def growth(rows: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Per load: ``ratio``, the time of the largest fruit count <= 96 (``to``) over that of the smallest (``from``)."""
    out = {}
    for load in dict.fromkeys(r["load"] for r in rows):
        sweep = sorted((r for r in rows if r["load"] == load and r["sweep"] == "fruit"), key=lambda r: r["fruit"])
        upto = [r for r in sweep if r["fruit"] <= 96]
        if len(upto) >= 2 and upto[0]["time_s"] > 0:
            out[load] = {"ratio": upto[-1]["time_s"] / upto[0]["time_s"], "from": upto[0]["fruit"], "to": upto[-1]["fruit"]}
    return out


def format_table(result: dict[str, Any]) -> list[list[str]]:
    """Rows of the printed table: load, fruit, views, boxes/view, time, CPU time, error, recall, precision."""
    out = []
    for r in result["rows"]:
        out.append(
            [
                r["load"],
                str(r["fruit"]),
                str(r["views"]),
                f"{r['boxes_per_view']:.0f}",
                f"{r['time_s']:.2f}",
                f"{r['cpu_s']:.2f}",
                "-" if r["mean_mm"] is None else f"{r['mean_mm']:.2f}",
                "-" if r["recall"] is None else f"{r['recall']:.3f}",
                "-" if r["precision"] is None else f"{r['precision']:.3f}",
            ]
        )
    return out


def write_json(result: dict[str, Any], path: str) -> None:
    """Write the result as JSON."""
    with open(path, "w") as fh:
        json.dump(result, fh, indent=2)
        fh.write("\n")


def write_figure(result: dict[str, Any], path: str) -> None:
    """Log-log figure of time against boxes (all views) for each load and sweep (needs matplotlib)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 4))
    for (load, sweep), marker in zip(
        [(ld, sw) for ld in dict.fromkeys(r["load"] for r in result["rows"]) for sw in ("fruit", "views")], "osv^"
    ):
        rows = sorted(
            (r for r in result["rows"] if r["load"] == load and r["sweep"] == sweep), key=lambda r: r["fruit"] * r["views"]
        )
        if rows:
            x = [r["boxes_per_view"] * r["views"] for r in rows]
            ax.loglog(x, [r["time_s"] for r in rows], marker=marker, label=f"{load}, {sweep} sweep")
    xs = np.array(
        [
            min(r["boxes_per_view"] * r["views"] for r in result["rows"]),
            max(r["boxes_per_view"] * r["views"] for r in result["rows"]),
        ]
    )
    t0 = min(r["time_s"] for r in result["rows"])
    ax.loglog(xs, t0 * xs / xs[0], "k:", label="linear")
    ax.set_xlabel("boxes (all views)")
    ax.set_ylabel("localize time, s (timing_s.total)")
    ax.set_title("bayes on a plant row (1280x720, 3 % box noise)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
