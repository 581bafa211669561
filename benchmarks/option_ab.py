"""The default ``localize`` against the same code with some options changed: runtime and accuracy, side by side.

Usage::

    python benchmarks/option_ab.py time [ROUNDS] -- KEY=VALUE ...
    python benchmarks/option_ab.py accuracy CONDITION FIRST LAST -- KEY=VALUE ...

``time`` alternates the two in one process (after a warm-up of each) on the paper scene (6 fruit, 3 views, the paper's
box noise, seed 3) and on six fruit of mixed shapes (seeds 0-4, as ``shape_time.py``), ``ROUNDS`` rounds (default 5),
and prints each one's median ``localize`` time (ms): a change's cost measured at one moment of this shared machine,
whose speed drifts by tens of per cent between minutes. ``accuracy`` runs a condition of ``monovisual3d bench
accuracy`` (its scenes, noise and matching) on seeds FIRST..LAST-1 with both and prints the mean, RMS, median and max
centre error (mm) of the matched fruit, recall and precision. Values are read as JSON where they parse
(``radius_max=0.08``, ``size_range=[0.01,0.15]``), else kept as text.

Example (2026-12-03, the search's radii 10-160 mm against the former 10-80 mm)::

    python benchmarks/option_ab.py time -- radius_max=0.08 n_radii=16
    python benchmarks/option_ab.py accuracy shapes-noise 100 140 -- radius_max=0.08 n_radii=16
"""

from __future__ import annotations

import json
import sys
import time
import warnings
from typing import Any

import numpy as np

import monovisual3d as mv
from monovisual3d.bench.accuracy import conditions, simulated_session
from monovisual3d.metrics import evaluate, match
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import paper_scene, shapes_scene
from monovisual3d.sim.simulate import simulate


def option_value(text: str) -> Any:
    """A ``KEY=VALUE`` option's value: a JSON number, list, boolean or null where it parses as one, else the text."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def split_options(argv: list[str], script: str) -> tuple[list[str], dict[str, Any]]:
    """A benchmark's own arguments (before ``--``) and the ``localize`` options after it (``KEY=VALUE``, values read by
    :func:`option_value`); exits with one line naming ``script`` on an option that is not ``KEY=VALUE``."""
    args, pairs = (argv[: argv.index("--")], argv[argv.index("--") + 1 :]) if "--" in argv else (argv, [])
    if any("=" not in p for p in pairs):
        sys.exit(f"{script}: options after -- must be KEY=VALUE (e.g. size_range=0.01,0.15), got {pairs}")
    return args, {k: option_value(v) for k, v in (p.split("=", 1) for p in pairs)}


def _variants(pairs: list[str]) -> dict[str, dict[str, Any]]:
    if not pairs or any("=" not in p for p in pairs):
        sys.exit(f"option_ab.py: after -- give options as KEY=VALUE (e.g. radius_max=0.08), got {pairs}")
    changed = {k: option_value(v) for k, v in (p.split("=", 1) for p in pairs)}
    return {"default": {}, " ".join(pairs): changed}


def timing(rounds: int, variants: dict[str, dict[str, Any]]) -> None:
    scenes = {
        "paper scene": [simulate(paper_scene(), noise=NoiseModel.paper(), rng=3)[0]],
        "mixed shapes": [simulated_session(shapes_scene("mixed", rng=s), NoiseModel(), s, masks=False)[0] for s in range(5)],
    }
    for sessions in scenes.values():
        for s in sessions:
            for opts in variants.values():
                mv.localize(s, **opts)
    times: dict[tuple[str, str], list[float]] = {(v, n): [] for v in variants for n in scenes}
    for _ in range(rounds):
        for v, opts in variants.items():
            for n, sessions in scenes.items():
                for s in sessions:
                    t0 = time.perf_counter()
                    mv.localize(s, **opts)
                    times[v, n].append(time.perf_counter() - t0)
    for v in variants:
        print(f"{v}: " + ", ".join(f"{n} {1e3 * float(np.median(times[v, n])):.0f} ms" for n in scenes))


def accuracy(name: str, seeds: range, variants: dict[str, dict[str, Any]]) -> None:
    cond = next((c for c in conditions() if c.name == name), None)
    if cond is None:
        sys.exit(f"option_ab.py: unknown condition {name!r}, expected one of {[c.name for c in conditions()]}")
    stats = {v: {"err": [], "tp": 0, "truth": 0, "est": 0} for v in variants}
    for seed in seeds:
        scene = cond.scene(seed)
        session, _ = simulated_session(scene, cond.noise, seed, masks=False)
        for v, opts in variants.items():
            est = mv.localize(session, **{**cond.method_options("bayes"), **opts}).positions
            m = evaluate(est, scene.centres, truth_radii=scene.radii)
            ei, ti = match(est, scene.centres)
            stats[v]["err"] += np.linalg.norm(est[ei] - scene.centres[ti], axis=1).tolist()
            stats[v]["tp"] += m.true_positives
            stats[v]["truth"] += m.n_truth
            stats[v]["est"] += m.n_estimates
    for v, s in stats.items():
        e = np.array(s["err"]) * 1e3
        print(
            f"{name} seeds {seeds.start}-{seeds.stop - 1}, {v}: mean {e.mean():.2f} rms {np.sqrt(np.mean(e**2)):.2f} "
            f"median {np.median(e):.2f} max {e.max():.1f} mm, recall {s['tp'] / s['truth']:.3f}, "
            f"precision {s['tp'] / max(s['est'], 1):.3f}"
        )


def main(argv: list[str]) -> None:
    if "--" not in argv or not argv or argv[0] not in ("time", "accuracy"):
        sys.exit(__doc__)
    head, pairs = argv[: argv.index("--")], argv[argv.index("--") + 1 :]
    variants = _variants(pairs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if head[0] == "time":
            timing(int(head[1]) if len(head) > 1 else 5, variants)
        elif len(head) == 4:
            accuracy(head[1], range(int(head[2]), int(head[3])), variants)
        else:
            sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
