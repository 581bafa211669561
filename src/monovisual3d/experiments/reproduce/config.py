"""Settings of the reproduction and the paper's published numbers it is compared with."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from ...errors import InputError
from ...limits import DEFAULT_KEEP_THRESHOLD, DEFAULT_REACH_M
from ...methods.paper.config import PaperConfig
from ...sim.noise import PAPER_BOX_SIGMA, PAPER_DROP_PROBABILITY

#: ``progress(done, total, description)``, called after each step.
ProgressFn = Callable[[int, int, str], None]

#: The paper's testbed table (real robot, OAK-1 camera; NOT a simulation), as published:
#: metres, m^2 for MSE, percent for MAPE.
PAPER_TESTBED_TABLE: dict[str, dict[str, float]] = {
    "square/weighted": {"euclidean_mean": 0.0205, "mse": 0.2187e-3, "rmse": 0.0148, "mae": 0.0100, "mape": 63.52},
    "square/geometric": {"euclidean_mean": 0.0206, "mse": 0.2197e-3, "rmse": 0.0148, "mae": 0.0101, "mape": 63.51},
    "gaussian/weighted": {"euclidean_mean": 0.0222, "mse": 0.3399e-3, "rmse": 0.0184, "mae": 0.0116, "mape": 57.35},
    "gaussian/geometric": {"euclidean_mean": 0.0204, "mse": 0.4960e-3, "rmse": 0.0223, "mae": 0.0127, "mape": 74.15},
}
#: The four configurations of the paper, in its table's column order.
PAPER_CONFIGS: tuple[tuple[str, str], ...] = tuple((k, c) for k in ("square", "gaussian") for c in ("weighted", "geometric"))
#: The paper's claim about the maximum simulation error (metres).
PAPER_MAX_ERROR_M = 0.010
#: The paper's configurations as ``kernel/centre`` labels (:attr:`RunRecord.label`).
PAPER_LABELS: tuple[str, ...] = tuple(f"{k}/{c}" for k, c in PAPER_CONFIGS)
NOISE_FREE, NOISY = "noise-free", "noisy"


@dataclass(frozen=True)
class ReproduceConfig:
    """Settings of :func:`reproduce`.

    Attributes
    ----------
    resolution : float, metres, grid cell of the paper method (the paper does not state its own)
    reach : float, metres, manipulator reach R; the paper's grid is a cube of side 2R in front of the first view
    seeds : int, noise draws of the noisy experiment (seeds ``seed .. seed + seeds - 1``)
    seed : int, first noise seed
    orderings : tuple of pose orderings, or None for all 3! = 6
    box_sigma, drop_probability : the paper's detector noise (0.05 relative box noise, 2 % drops)
    sigma_fraction_noise_free, sigma_fraction_noisy : Gaussian sigma / box size (paper: 1/2, and 1/3 with noise)
    keep_threshold : float, relative posterior threshold of the clustered cells (the library's default)
    thresholds : tuple of float, thresholds of the sensitivity table (weighted centre)
    ghost_counts : tuple of int, fruit per random scene in the ghost study
    ghost_scenes : int, random scenes per count
    ghost_seed : int, base seed of the random scenes
    bayes : bool, also run the ``bayes`` method
    figures : bool, write the figures (needs matplotlib, extra ``[viz]``)
    quick : bool, marks a reduced run in the report
    """

    resolution: float = 0.015
    reach: float = DEFAULT_REACH_M
    seeds: int = 5
    seed: int = 0
    orderings: tuple[tuple[int, ...], ...] | None = None
    box_sigma: float = PAPER_BOX_SIGMA
    drop_probability: float = PAPER_DROP_PROBABILITY
    sigma_fraction_noise_free: float = 0.5
    sigma_fraction_noisy: float = 1.0 / 3.0
    keep_threshold: float = DEFAULT_KEEP_THRESHOLD
    thresholds: tuple[float, ...] = (0.1, 0.25, 0.5, 0.75)
    ghost_counts: tuple[int, ...] = (1, 2, 4, 6, 10)
    ghost_scenes: int = 3
    ghost_seed: int = 2024
    bayes: bool = True
    figures: bool = True
    quick: bool = False

    def __post_init__(self) -> None:
        if not (isinstance(self.seeds, int) and self.seeds >= 1):
            raise InputError(f"seeds: got {self.seeds!r}, expected a positive integer")
        if not (isinstance(self.ghost_scenes, int) and self.ghost_scenes >= 1):
            raise InputError(f"ghost_scenes: got {self.ghost_scenes!r}, expected a positive integer")
        if self.orderings is not None:
            for o in self.orderings:
                if sorted(o) != [0, 1, 2]:
                    raise InputError(f"orderings: got {o!r}, expected permutations of (0, 1, 2)")
        if any(not 0 < t <= 1 for t in (*self.thresholds, self.keep_threshold)):
            raise InputError("thresholds: expected values in (0, 1]")
        if any(not (isinstance(n, int) and n >= 1) for n in self.ghost_counts):
            raise InputError(f"ghost_counts: got {self.ghost_counts!r}, expected positive integers")
        PaperConfig(resolution=self.resolution, reach=self.reach)  # validates both

    @classmethod
    def quick_config(cls, **overrides: Any) -> ReproduceConfig:
        """A reduced run for tests (< 20 s): 3 cm grid, 1 seed, 2 orderings, 2 thresholds, 2 ghost scenes."""
        base = cls(
            resolution=0.03,
            seeds=1,
            orderings=((0, 1, 2), (1, 2, 0)),
            thresholds=(0.1, 0.5),
            ghost_counts=(1, 4),
            ghost_scenes=1,
            quick=True,
        )
        return replace(base, **overrides)
