"""The shape-fit benchmark runs and its clean rows meet the issue's noise-free targets."""

from __future__ import annotations

from monovisual3d.bench.shape_fit import markdown, run_shape_fit


def test_shape_fit_benchmark_one_seed() -> None:
    results = run_shape_fit(seeds=1, scene="mixed")
    clean, noise = results["rows"]["clean"], results["rows"]["noise"]
    assert clean["spheroid"]["n"] == 6
    # known association, whole-pixel boxes: the upright spheroid is within the noise-free targets
    assert clean["spheroid"]["mean_mm"] <= 1.5 and clean["spheroid"]["semi_axis_error_mm"] <= 2.0
    assert clean["sphere"]["semi_axis_error_mm"] > 5.0  # a sphere cannot hold a cucumber
    assert noise["spheroid"]["rms_bound_mm"] > 0 and "rms_bound_mm" not in clean["spheroid"]
    assert "| noise | spheroid |" in markdown(results)
