"""Metrics against hand-computed values: the paper's Eqs. 10-13, Hungarian matching, misses and false positives."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d import evaluate
from monovisual3d.metrics import match, paper_errors

TRUTH = np.array([[0.5, 0.1, 0.4], [0.6, -0.2, 0.5]])
# errors (estimate - truth): object 0: (+0.01, -0.02, +0.02) -> 30 mm; object 1: (0, +0.004, -0.003) -> 5 mm
EST = np.array([[0.6, -0.196, 0.497], [0.51, 0.08, 0.42]])  # listed in the other order


def test_paper_errors_hand_computed() -> None:
    d = np.array([0.01, -0.02, 0.02, 0.0, 0.004, -0.003])
    t = TRUTH.ravel()
    e = paper_errors(EST[::-1], TRUTH)
    assert e["mae"] == pytest.approx((0.01 + 0.02 + 0.02 + 0.0 + 0.004 + 0.003) / 6, rel=1e-12)
    assert e["mse"] == pytest.approx((1e-4 + 4e-4 + 4e-4 + 0 + 16e-6 + 9e-6) / 6, rel=1e-12)
    assert e["rmse"] == pytest.approx(math.sqrt(e["mse"]), rel=1e-12)
    mape = 100 / 6 * (0.01 / 0.5 + 0.02 / 0.1 + 0.02 / 0.4 + 0.0 / 0.6 + 0.004 / 0.2 + 0.003 / 0.5)
    assert e["mape"] == pytest.approx(mape, rel=1e-12)
    assert e["mape"] == pytest.approx(100 * np.mean(np.abs(d / t)), rel=1e-12)
    assert e["euclidean_mean"] == pytest.approx((0.03 + 0.005) / 2, rel=1e-12)
    assert e["euclidean_median"] == pytest.approx(0.0175, rel=1e-12)
    assert e["euclidean_max"] == pytest.approx(0.03, rel=1e-12)


def test_paper_errors_zero_truth_coordinates_are_left_out_of_mape() -> None:
    """MAPE divides by the true coordinate; exact zeros are skipped rather than giving inf."""
    e = paper_errors([[0.51, 0.01, 0.4]], [[0.5, 0.0, 0.4]])
    assert e["mape"] == pytest.approx(100 * (0.01 / 0.5 + 0.0) / 2, rel=1e-12)
    assert math.isfinite(e["mape"])


def test_paper_errors_empty_is_nan() -> None:
    assert all(math.isnan(v) for v in paper_errors(np.zeros((0, 3)), np.zeros((0, 3))).values())


def test_match_minimises_total_distance_not_greedy() -> None:
    """Greedy nearest-first would pair e1 with t0 (0.1) and e0 with t1 (2.5): total 2.6. Optimal total is 2.4."""
    est = [[0.0, 0, 0], [1.1, 0, 0]]
    truth = [[1.0, 0, 0], [2.5, 0, 0]]
    ei, ti = match(est, truth)
    assert dict(zip(ei.tolist(), ti.tolist())) == {0: 0, 1: 1}


def test_match_unequal_sizes(rng: np.random.Generator) -> None:
    truth = rng.uniform(0, 1, (5, 3))
    est = truth[[3, 1]] + 1e-3
    ei, ti = match(est, truth)
    assert ei.tolist() == [0, 1] and ti.tolist() == [3, 1]
    assert match(np.zeros((0, 3)), truth)[0].shape == (0,)


def test_evaluate_matches_then_scores() -> None:
    m = evaluate(EST, TRUTH)
    assert (m.n_truth, m.n_estimates, m.n_matched) == (2, 2, 2)
    assert (m.true_positives, m.misses, m.false_positives) == (2, 0, 0)
    assert (m.recall, m.precision) == (1.0, 1.0)
    assert m.mae == pytest.approx(paper_errors(EST[::-1], TRUTH)["mae"], rel=1e-12)
    assert m.euclidean_max == pytest.approx(0.03, rel=1e-12)


def test_gate_turns_far_pairs_into_miss_plus_false_positive() -> None:
    # default gate without radii: 50 mm. Both pairs (30 and 5 mm) pass.
    assert evaluate(EST, TRUTH).true_positives == 2
    # explicit 20 mm gate: the 30 mm pair is a miss and a false positive, but still counts in the errors
    m = evaluate(EST, TRUTH, gate=0.02)
    assert (m.true_positives, m.misses, m.false_positives) == (1, 1, 1)
    assert (m.recall, m.precision) == (0.5, 0.5)
    assert m.euclidean_max == pytest.approx(0.03, rel=1e-12)
    # radius gate: max(radius, 20 mm): radius 35 mm lets the 30 mm pair through, 25 mm does not
    assert evaluate(EST, TRUTH, truth_radii=[0.035, 0.01]).true_positives == 2
    assert evaluate(EST, TRUTH, truth_radii=[0.025, 0.001]).true_positives == 1


def test_unknown_radius_uses_the_default_gate() -> None:
    m = evaluate(EST, TRUTH, truth_radii=[math.nan, 0.03])
    assert m.true_positives == 2  # 30 mm pair against the 50 mm default gate, not against NaN


def test_unpaired_truth_and_estimates() -> None:
    truth = np.vstack([TRUTH, [[0.9, 0.0, 0.9]]])
    m = evaluate(EST, truth)
    assert (m.n_matched, m.true_positives, m.misses, m.false_positives) == (2, 2, 1, 0)
    assert m.recall == pytest.approx(2 / 3)
    extra = np.vstack([EST, [[0.0, 0.0, 0.0]]])
    m = evaluate(extra, TRUTH)
    assert (m.n_matched, m.true_positives, m.misses, m.false_positives) == (2, 2, 0, 1)
    assert m.precision == pytest.approx(2 / 3)
    m = evaluate(np.zeros((0, 3)), TRUTH)
    assert (m.misses, m.false_positives, m.recall) == (2, 0, 0.0)
    assert math.isnan(m.precision) and math.isnan(m.mae)


def test_radius_error() -> None:
    m = evaluate(EST, TRUTH, truth_radii=[0.03, 0.04], estimate_radii=[0.045, 0.028])  # est 0 pairs with truth 1
    assert m.radius_error_mean == pytest.approx((0.005 + 0.002) / 2, rel=1e-12)
    m = evaluate(EST, TRUTH, truth_radii=[0.03, 0.04], estimate_radii=[math.nan, 0.028])
    assert m.radius_error_mean == pytest.approx(0.002, rel=1e-12)
    assert evaluate(EST, TRUTH, truth_radii=[0.03, 0.04]).radius_error_mean is None
    # a truth object of unknown radius is left out of the mean instead of making it NaN
    m = evaluate(EST, TRUTH, truth_radii=[0.03, math.nan], estimate_radii=[0.045, 0.028])
    assert m.radius_error_mean == pytest.approx(0.002, rel=1e-12)


def test_metrics_to_dict() -> None:
    d = evaluate(EST, TRUTH).to_dict()
    assert {"mae", "mse", "rmse", "mape", "misses", "false_positives", "recall", "precision"} <= set(d)
    assert_allclose(d["rmse"], math.sqrt(d["mse"]))
