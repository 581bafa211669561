"""Re-run the paper's simulation experiments and write a Markdown report with figures.

What runs (all on the simulator's bounding-box camera, :mod:`monovisual3d.sim`):

1. **Noise-free simulation** (the paper's first essay): the ``paper`` scene
   (six spheres of 5 and 10 cm diameter about 0.5 m from the camera) seen from
   the paper's three poses, exact visible boxes; the ``paper`` method with the
   square kernel and with the Gaussian kernel (sigma = size / 2), each with the
   weighted and the geometric cluster centre, for every ordering
   (permutation) of the three poses.
2. **Noisy simulation** (the second essay): the same with the paper's detector
   noise (box centre and size N(0, 0.05) relative to the box size, 2 % missed
   detections; :class:`~monovisual3d.sim.noise.NoiseModel`), ``seeds`` noise
   draws, Gaussian sigma = size / 3 as the paper used with noise. Each draw is
   simulated once in the canonical pose order and its views are then permuted,
   so all orderings see the same detections (as the paper's testbed runs did).
3. **Threshold sensitivity**: which cells enter k-means is not stated in the
   paper; the weighted-centre estimates are recomputed for several relative
   thresholds ``keep_threshold`` (cells with ``p >= keep_threshold * max(p)``).
4. **Ghost study**: noise-free random scenes with 1, 2, 4, 6 and 10 fruit
   (fixed seeds), the ``paper`` method (both kernels, weighted centre) and the
   ``bayes`` method side by side, plus the posterior mass of the clustered
   cells that lies off every fruit.
5. The ``bayes`` method is also run on experiments 1 and 2, for reference.

Metrics (:mod:`monovisual3d.metrics`): per run, estimates are matched to the
truth (Hungarian); the paper's Euclidean mean, MSE, RMSE, MAE and MAPE are
computed over all matched pairs pooled over fruit, orderings and seeds;
misses and false positives use the default gate of
:func:`~monovisual3d.metrics.evaluate` (the true radius, at least 20 mm).

The order of the pose permutations only matters through the grid: the
paper's grid is placed in front of the first view with a detection, and the
filter's product over views is commutative.

The package is split by stage: :mod:`.config` (settings and the paper's
numbers), :mod:`.run` (running the experiments), :mod:`.aggregate` (per-run
records and pooled :class:`~monovisual3d.metrics.Metrics`), :mod:`.figures`
(matplotlib) and :mod:`.report` (``report.md`` from the text template
``report.md.tmpl``).
"""

from __future__ import annotations

from .aggregate import Aggregate, ReproduceResult, RunRecord, aggregate_records
from .config import (
    NOISE_FREE,
    NOISY,
    PAPER_CONFIGS,
    PAPER_LABELS,
    PAPER_MAX_ERROR_M,
    PAPER_TESTBED_TABLE,
    ProgressFn,
    ReproduceConfig,
)
from .report import (
    configuration_table,
    ghost_table,
    ordering_table,
    render_report,
    statements_table,
    testbed_table,
    threshold_table,
)
from .run import off_fruit_mass, reorder_session, reproduce

__all__ = [
    "NOISE_FREE",
    "NOISY",
    "PAPER_CONFIGS",
    "PAPER_LABELS",
    "PAPER_MAX_ERROR_M",
    "PAPER_TESTBED_TABLE",
    "Aggregate",
    "ProgressFn",
    "ReproduceConfig",
    "ReproduceResult",
    "RunRecord",
    "aggregate_records",
    "configuration_table",
    "ghost_table",
    "off_fruit_mass",
    "ordering_table",
    "render_report",
    "reorder_session",
    "reproduce",
    "statements_table",
    "testbed_table",
    "threshold_table",
]
