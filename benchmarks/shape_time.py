"""Runtime of the default method on six-fruit scenes of mixed shapes (the shape issue's runtime row).

Five seeds of the ``mixed`` preset, exact boxes, three runs each after one warm-up; prints the median,
min and max of one ``localize`` call. Run it idle and with another process busy on one core.
"""

from __future__ import annotations

import statistics
import time
import warnings

import monovisual3d as mv
from monovisual3d.bench.accuracy import simulated_session
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import shapes_scene


def main() -> None:
    warnings.simplefilter("ignore")
    times = []
    for seed in range(5):
        session, _ = simulated_session(shapes_scene("mixed", rng=seed), NoiseModel(), seed, masks=False)
        mv.localize(session)
        for _ in range(3):
            t0 = time.perf_counter()
            mv.localize(session)
            times.append(time.perf_counter() - t0)
    ms = [1000 * t for t in times]
    print(
        f"default bayes, six fruit of mixed shapes (5 seeds x 3 runs): median {statistics.median(ms):.0f} ms, min {min(ms):.0f}, max {max(ms):.0f}"
    )


if __name__ == "__main__":
    main()
