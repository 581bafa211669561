"""Runtime of the default method on six-fruit scenes of mixed shapes (the shape issue's runtime row).

Five seeds of the ``mixed`` preset, exact boxes, three runs each after one warm-up; prints the median,
min and max of one ``localize`` call. Run it idle and with another process busy on one core.

Usage: python experiments/shape_time.py [--seeds 5] [--runs 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import monovisual3d as mv
from monovisual3d.bench.accuracy import simulated_session
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import shapes_scene


def main(n_seeds: int, runs: int) -> None:
    warnings.simplefilter("ignore")
    times = []
    for seed in range(n_seeds):
        session, _ = simulated_session(shapes_scene("mixed", rng=seed), NoiseModel(), seed, masks=False)
        mv.localize(session)
        for _ in range(runs):
            t0 = time.perf_counter()
            mv.localize(session)
            times.append(time.perf_counter() - t0)
    ms = [1000 * t for t in times]
    print(
        f"default bayes, six fruit of mixed shapes ({n_seeds} seeds x {runs} runs): median {statistics.median(ms):.0f} ms, "
        f"min {min(ms):.0f}, max {max(ms):.0f}"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=5, help="scenes, seeds 0..SEEDS-1 (default 5)")
    parser.add_argument("--runs", type=int, default=3, help="timed runs per scene after one warm-up (default 3)")
    args = parser.parse_args()
    if args.seeds < 1 or args.runs < 1:
        parser.error(f"--seeds and --runs: got {args.seeds} and {args.runs}, expected at least 1 each")
    main(args.seeds, args.runs)
