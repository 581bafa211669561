"""Runtime of the default method on six-fruit scenes of mixed shapes (the shape issue's runtime row)."""

import statistics
import time
import warnings

warnings.simplefilter("ignore")
import monovisual3d as mv
from monovisual3d.bench.accuracy import simulated_session
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import shapes_scene

ts = []
for seed in range(5):
    session, _ = simulated_session(shapes_scene("mixed", rng=seed), NoiseModel(), seed, masks=False)
    mv.localize(session)
    for _ in range(3):
        t = time.perf_counter()
        mv.localize(session)
        ts.append(time.perf_counter() - t)
print(
    f"default bayes on mixed-shape six-fruit scenes (5 seeds x 3 runs): median {1000 * statistics.median(ts):.0f} ms, min {1000 * min(ts):.0f}, max {1000 * max(ts):.0f}"
)
