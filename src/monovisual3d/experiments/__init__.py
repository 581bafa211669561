"""Experiments on simulated data: the paper's reproduction and the demo.

- :func:`~monovisual3d.experiments.reproduce.reproduce` re-runs the paper's
  simulation experiments (noise-free and noisy, all pose orderings, square vs
  Gaussian kernel, weighted vs geometric centre) plus a ghost study, and writes
  a Markdown report with figures.
- :func:`~monovisual3d.experiments.demo.run_demo` simulates a greenhouse truss,
  localises it and evaluates the result (the ``monovisual3d demo`` command).
"""

from __future__ import annotations

from .demo import DemoResult, run_demo
from .reproduce import ReproduceConfig, ReproduceResult, reproduce

__all__ = ["DemoResult", "ReproduceConfig", "ReproduceResult", "reproduce", "run_demo"]
