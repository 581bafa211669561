"""Pooling runs of the reproduction: the pooled Aggregate is the Metrics of evaluate() on the runs' union."""

from __future__ import annotations

import math
from dataclasses import asdict, fields

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.experiments.reproduce import Aggregate, ReproduceConfig, ReproduceResult, aggregate_records
from monovisual3d.experiments.reproduce.aggregate import record_run, select
from monovisual3d.metrics import Metrics, evaluate
from monovisual3d.result import DetectedObject
from monovisual3d.sim.scene import Scene, Sphere


def _scene(centres: list[list[float]], radii: list[float]) -> Scene:
    return Scene(tuple(Sphere(np.array(c, dtype=float), r) for c, r in zip(centres, radii)))


def _objects(positions: list[list[float]]) -> list[DetectedObject]:
    return [DetectedObject(position=np.array(p, dtype=float), score=1.0) for p in positions]


# Two runs whose truth sets are 10 m apart, so matching each run alone pairs the same rows as matching their union.
# (Both runs have at most as many estimates as fruit: an unpaired estimate in one run and an unpaired fruit in
# the other would be paired with each other in the union.) Run A: three fruit, one estimate 4 mm off, one 30 mm
# off (a miss + false positive at the 25 mm radius gate), one fruit not found. Run B: two fruit, 2 mm and 0 mm off.
TRUTH_A = [[0.5, 0.0, 0.4], [0.6, 0.1, 0.5], [0.7, -0.1, 0.45]]
RADII_A = [0.03, 0.025, 0.04]
EST_A = [[0.504, 0.0, 0.4], [0.6, 0.13, 0.5]]
TRUTH_B = [[10.5, 0.0, 0.4], [10.6, 0.2, 0.3]]
RADII_B = [0.05, 0.03]
EST_B = [[10.5, 0.002, 0.4], [10.6, 0.2, 0.3]]


@pytest.fixture
def records() -> list:
    a = record_run("noise-free", "paper", "square", "weighted", 0.1, (0, 1, 2), None, _scene(TRUTH_A, RADII_A), _objects(EST_A))
    b = record_run("noise-free", "paper", "square", "weighted", 0.1, (1, 2, 0), None, _scene(TRUTH_B, RADII_B), _objects(EST_B))
    a.off_fruit_mass, b.off_fruit_mass = 0.2, 0.6
    return [a, b]


def test_aggregate_equals_evaluate_on_the_union(records: list) -> None:
    agg = aggregate_records(records)
    ref = evaluate(EST_A + EST_B, TRUTH_A + TRUTH_B, truth_radii=RADII_A + RADII_B)
    assert isinstance(agg, Metrics)
    for f in fields(Metrics):
        if f.name == "radius_error_mean":
            continue
        got, want = getattr(agg, f.name), getattr(ref, f.name)
        if want is None:  # shape metrics: the records have no semi-axes, so neither side reports them
            assert got is None, f.name
            continue
        assert_allclose(got, want, rtol=1e-12, atol=0, err_msg=f.name)
    # the hand-counted values, so a change in evaluate() itself shows up here too
    assert (agg.n_truth, agg.n_estimates, agg.n_matched) == (5, 4, 4)
    assert (agg.true_positives, agg.misses, agg.false_positives) == (3, 2, 1)
    assert_allclose(agg.recall, 3 / 5)
    assert_allclose(agg.precision, 3 / 4)
    assert_allclose(np.sort(agg.errors_m), [0.0, 0.002, 0.004, 0.03], atol=1e-12)
    assert_allclose(agg.euclidean_max, 0.03)
    assert_allclose(agg.euclidean_mean, 0.036 / 4)


def test_aggregate_bookkeeping(records: list) -> None:
    agg = aggregate_records(records)
    assert agg.runs == 2
    assert_allclose(agg.off_fruit_mass, 0.4)
    assert agg.radius_error_mean is None
    records[1].off_fruit_mass = math.nan  # runs without a posterior (bayes) do not enter the mean
    assert_allclose(aggregate_records(records).off_fruit_mass, 0.2)


def test_aggregate_of_no_runs_is_empty() -> None:
    agg = aggregate_records([])
    assert isinstance(agg, Aggregate)
    assert (agg.runs, agg.n_truth, agg.misses) == (0, 0, 0)
    assert math.isnan(agg.euclidean_mean) and math.isnan(agg.recall) and math.isnan(agg.off_fruit_mass)
    assert agg.errors_m.shape == (0,)
    assert set(asdict(agg)) >= {f.name for f in fields(Metrics)}


def test_select_and_result_aggregate_filter_by_configuration(records: list) -> None:
    bayes = record_run("noise-free", "bayes", "-", "-", math.nan, (0, 1, 2), None, _scene(TRUTH_A, RADII_A), _objects(TRUTH_A))
    other_thr = record_run(
        "noise-free", "paper", "square", "weighted", 0.5, (0, 1, 2), None, _scene(TRUTH_A, RADII_A), _objects(EST_A)
    )
    allr = [*records, bayes, other_thr]
    assert select(allr, "noise-free", "square/weighted", 0.1) == records
    assert select(allr, "noise-free", "square/weighted", 0.5) == [other_thr]
    assert select(allr, "noise-free", "bayes", 0.1) == [bayes]  # bayes has no threshold
    assert select(allr, "noise-free", "square/weighted", 0.1, ordering=(1, 2, 0)) == [records[1]]
    assert select(allr, "noise-free", "square/weighted", 0.1, n_fruit=3) == [records[0]]
    assert select(allr, "noisy", "square/weighted", 0.1) == []
    result = ReproduceResult(ReproduceConfig(keep_threshold=0.1), allr, None, {}, 0.0, [])  # type: ignore[arg-type]
    assert result.aggregate("noise-free", "square/weighted").runs == 2
    assert result.aggregate("noise-free", "bayes").euclidean_max == 0.0
