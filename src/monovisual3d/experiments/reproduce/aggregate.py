"""Per-run records of the reproduction and the metrics pooled over runs.

One :class:`RunRecord` per localisation run holds the run's own
:class:`~monovisual3d.metrics.Metrics` (from :func:`~monovisual3d.metrics.evaluate`)
and its matched pairs. :func:`aggregate_records` pools several runs into an
:class:`Aggregate`, which *is* a :class:`~monovisual3d.metrics.Metrics`: the
error metrics come from :func:`~monovisual3d.metrics.paper_errors` on all
matched pairs together, the detection counts are the sums of the runs' gated
counts. So pooling runs whose truth sets are far apart gives what
:func:`~monovisual3d.metrics.evaluate` gives on their union.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...metrics import Metrics, evaluate, match, paper_errors
from ...result import DetectedObject
from ...sim.scene import Scene
from .config import ReproduceConfig


@dataclass
class RunRecord:
    """One localisation run of the reproduction.

    Attributes
    ----------
    experiment : "noise-free", "noisy" or "ghost"
    method : "paper" or "bayes"
    kernel, centre : paper configuration ("-" for bayes)
    keep_threshold : float (NaN for bayes)
    ordering : tuple of pose indices
    seed : int or None, noise seed or random-scene seed
    n_fruit : int, fruit in the scene
    estimates : ndarray, shape (K, 3), metres, base frame
    estimate_radii : list of float or None
    paired_estimates, paired_truth : ndarray, shape (P, 3), matched rows (Hungarian, ungated)
    metrics : Metrics
    off_fruit_mass : float, posterior mass of the clustered cells outside every true sphere (paper method)
    n_clustered : int, cells that entered k-means (paper method)
    skipped_views : int, views the paper filter skipped (no detection, or contradicting the prior)
    seconds : float, filter (+ estimate) time
    """

    experiment: str
    method: str
    kernel: str
    centre: str
    keep_threshold: float
    ordering: tuple[int, ...]
    seed: int | None
    n_fruit: int
    estimates: NDArray[np.float64]
    estimate_radii: list[float | None]
    paired_estimates: NDArray[np.float64]
    paired_truth: NDArray[np.float64]
    metrics: Metrics
    off_fruit_mass: float = math.nan
    n_clustered: int = 0
    skipped_views: int = 0
    seconds: float = 0.0

    @property
    def label(self) -> str:
        return "bayes" if self.method == "bayes" else f"{self.kernel}/{self.centre}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "experiment": self.experiment,
            "method": self.method,
            "kernel": self.kernel,
            "centre": self.centre,
            "keep_threshold": None if math.isnan(self.keep_threshold) else self.keep_threshold,
            "ordering": list(self.ordering),
            "seed": self.seed,
            "n_fruit": self.n_fruit,
            "estimates": self.estimates.tolist(),
            "estimate_radii": self.estimate_radii,
            "errors_m": np.linalg.norm(self.paired_estimates - self.paired_truth, axis=1).tolist(),
            "metrics": self.metrics.to_dict(),
            "off_fruit_mass": None if math.isnan(self.off_fruit_mass) else self.off_fruit_mass,
            "n_clustered": self.n_clustered,
            "skipped_views": self.skipped_views,
            "seconds": self.seconds,
        }


def record_run(
    experiment: str,
    method: str,
    kernel: str,
    centre: str,
    keep_threshold: float,
    ordering: tuple[int, ...],
    seed: int | None,
    scene: Scene,
    objects: list[DetectedObject],
    **extra: Any,
) -> RunRecord:
    """Evaluate one run's objects against the scene (:func:`~monovisual3d.metrics.evaluate`) and keep the pairs."""
    est = np.array([o.position for o in objects]).reshape(-1, 3)
    radii = [None if o.radius is None else float(o.radius) for o in objects]
    ei, ti = match(est, scene.centres)
    est_r = np.array([np.nan if r is None else r for r in radii]) if any(r is not None for r in radii) else None
    m = evaluate(est, scene.centres, truth_radii=scene.radii, estimate_radii=est_r)
    return RunRecord(
        experiment,
        method,
        kernel,
        centre,
        keep_threshold,
        ordering,
        seed,
        len(scene.fruits),
        est,
        radii,
        est[ei],
        scene.centres[ti],
        m,
        **extra,
    )


@dataclass
class Aggregate(Metrics):
    """:class:`~monovisual3d.metrics.Metrics` pooled over runs (all matched pairs together), plus run bookkeeping.

    Attributes
    ----------
    runs : int, runs pooled
    off_fruit_mass : float, mean over the runs that have one (NaN when none has)
    errors_m : ndarray, shape (P,), metres, Euclidean error of every pooled pair

    ``radius_error_mean`` is None: the runs keep their radius errors only as means.
    """

    runs: int = 0
    off_fruit_mass: float = math.nan
    errors_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)


def aggregate_records(records: Sequence[RunRecord]) -> Aggregate:
    """Pool the matched pairs of several runs and compute the paper's metrics on them.

    Examples
    --------
    >>> aggregate_records([]).runs
    0
    """
    if records:
        E = np.concatenate([r.paired_estimates for r in records])
        T = np.concatenate([r.paired_truth for r in records])
    else:
        E = T = np.zeros((0, 3))
    n_truth = sum(r.metrics.n_truth for r in records)
    n_estimates = sum(r.metrics.n_estimates for r in records)
    tp = sum(r.metrics.true_positives for r in records)
    mass = [r.off_fruit_mass for r in records if not math.isnan(r.off_fruit_mass)]
    return Aggregate(
        n_truth=n_truth,
        n_estimates=n_estimates,
        n_matched=sum(r.metrics.n_matched for r in records),
        true_positives=tp,
        misses=sum(r.metrics.misses for r in records),
        false_positives=sum(r.metrics.false_positives for r in records),
        recall=tp / n_truth if n_truth else math.nan,
        precision=tp / n_estimates if n_estimates else math.nan,
        runs=len(records),
        off_fruit_mass=float(np.mean(mass)) if mass else math.nan,
        errors_m=np.linalg.norm(E - T, axis=1),
        **paper_errors(E, T),
    )


def select(
    records: Sequence[RunRecord],
    experiment: str,
    label: str,
    keep_threshold: float,
    *,
    n_fruit: int | None = None,
    ordering: tuple[int, ...] | None = None,
) -> list[RunRecord]:
    """The runs of one experiment and configuration; paper runs only at ``keep_threshold``."""
    return [
        r
        for r in records
        if r.experiment == experiment
        and r.label == label
        and (r.method == "bayes" or math.isclose(r.keep_threshold, keep_threshold))
        and (n_fruit is None or r.n_fruit == n_fruit)
        and (ordering is None or r.ordering == ordering)
    ]


@dataclass
class ReproduceResult:
    """What :func:`~monovisual3d.experiments.reproduce.reproduce` measured and wrote."""

    config: ReproduceConfig
    records: list[RunRecord]
    report: Path
    files: dict[str, Path]
    seconds: float
    notes: list[str]

    def aggregate(
        self, experiment: str, label: str, keep_threshold: float | None = None, n_fruit: int | None = None
    ) -> Aggregate:
        """Pooled metrics of the runs of one experiment and configuration (``label`` as in :attr:`RunRecord.label`)."""
        thr = self.config.keep_threshold if keep_threshold is None else keep_threshold
        return aggregate_records(select(self.records, experiment, label, thr, n_fruit=n_fruit))
