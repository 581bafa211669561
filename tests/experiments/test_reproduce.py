"""The reproduction in quick mode: report tables, figures, raw results, and the helpers it is built from."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.errors import InputError
from monovisual3d.experiments.reproduce import (
    PAPER_CONFIGS,
    ReproduceConfig,
    ReproduceResult,
    aggregate_records,
    off_fruit_mass,
    reorder_session,
    reproduce,
)
from monovisual3d.grid import VoxelGrid
from monovisual3d.sim.scene import Scene, Sphere
from monovisual3d.sim.scenes import paper_scene
from monovisual3d.sim.simulate import simulate

pytest.importorskip("matplotlib")


@pytest.fixture(scope="module")
def quick(tmp_path_factory: pytest.TempPathFactory) -> tuple[ReproduceResult, Path, list[tuple[int, int, str]]]:
    out = tmp_path_factory.mktemp("reproduce")
    calls: list[tuple[int, int, str]] = []
    result = reproduce(out, ReproduceConfig.quick_config(), progress=lambda d, t, w: calls.append((d, t, w)))
    return result, out, calls


def test_quick_writes_report_results_and_figures(quick: tuple[ReproduceResult, Path, list]) -> None:
    result, out, _ = quick
    for name in (
        "report.md",
        "results.json",
        "errors_boxplot.png",
        "posterior_square.png",
        "posterior_gaussian.png",
        "ghost_study.png",
    ):
        path = out / name
        assert path.is_file() and path.stat().st_size > 0, name
        if name.endswith(".png"):
            assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = (out / "report.md").read_text()
    # every figure written is linked from the report
    for key, path in result.files.items():
        if path.suffix == ".png":
            assert f"]({path.name})" in report, key


def test_report_has_the_expected_tables_and_rows(quick: tuple[ReproduceResult, Path, list]) -> None:
    report = (quick[1] / "report.md").read_text()
    for heading in (
        "## What the paper publishes",
        "### Noise-free simulation",
        "### Noisy simulation",
        "### Pose orderings",
        "### Sensitivity to the k-means cell threshold",
        "## Ghost study",
        "## Discussion",
        "## Runtime",
    ):
        assert heading in report, heading
    header = "| metric | Square weighted | Square geometric | Gaussian weighted | Gaussian geometric | bayes (reference) |"
    assert report.count(header) == 2  # noise-free and noisy
    for row in (
        "| Euclidean error, mean (mm) |",
        "| MSE (mm²) |",
        "| RMSE (mm) |",
        "| MAE (mm) |",
        "| MAPE (%) |",
        "| misses / fruit |",
    ):
        assert report.count(row) >= 2, row
    # the paper's testbed table, as published (converted to mm), is shown for reference
    assert "| Euclidean error, mean (mm) | 20.5 | 20.6 | 22.2 | 20.4 |" in report
    assert "| MAPE (%) | 63.52 | 63.51 | 57.35 | 74.15 |" in report
    assert "Quick mode" in report
    # ghost study: one row per fruit count of the quick config
    for n in ReproduceConfig.quick_config().ghost_counts:
        assert f"\n| {n} | 1 |" in report


def test_report_numbers_are_the_measured_ones(quick: tuple[ReproduceResult, Path, list]) -> None:
    result, out, _ = quick
    report = (out / "report.md").read_text()
    cfg = result.config
    runs = len(cfg.orderings or ())
    for experiment in ("noise-free", "noisy"):
        for kernel, centre in PAPER_CONFIGS:
            a = result.aggregate(experiment, f"{kernel}/{centre}")
            assert a.runs == runs * (cfg.seeds if experiment == "noisy" else 1)
            assert a.n_truth == 6 * a.runs
            assert f"{1e3 * a.euclidean_mean:.2f}" in report
    # bayes localises the noise-free paper scene almost exactly: a report that could not say so would be wrong
    b = result.aggregate("noise-free", "bayes")
    assert b.misses == 0 and b.euclidean_max < 0.005


def test_results_json_matches_records(quick: tuple[ReproduceResult, Path, list]) -> None:
    result, out, _ = quick
    data = json.loads((out / "results.json").read_text())
    assert len(data["records"]) == len(result.records)
    r0, d0 = result.records[0], data["records"][0]
    assert_allclose(d0["errors_m"], np.linalg.norm(r0.paired_estimates - r0.paired_truth, axis=1))
    assert data["config"]["resolution"] == result.config.resolution


def test_progress_reaches_total(quick: tuple[ReproduceResult, Path, list]) -> None:
    calls = quick[2]
    assert calls and calls[-1][0] == calls[-1][1]
    assert [c[0] for c in calls] == list(range(1, len(calls) + 1))


def test_config_rejects_bad_values() -> None:
    with pytest.raises(InputError, match="seeds"):
        ReproduceConfig(seeds=0)
    with pytest.raises(InputError, match="orderings"):
        ReproduceConfig(orderings=((0, 1, 1),))
    with pytest.raises(InputError, match="resolution"):
        ReproduceConfig(resolution=-1.0)
    with pytest.raises(InputError, match="thresholds"):
        ReproduceConfig(thresholds=(0.0,))


def test_reorder_session_permutes_views() -> None:
    s, _ = simulate(paper_scene(), rng=0)
    r = reorder_session(s, (2, 0, 1))
    assert [id(v) for v in r.views] == [id(s.views[i]) for i in (2, 0, 1)]
    with pytest.raises(InputError, match="permutation"):
        reorder_session(s, (0, 0, 1))


def test_off_fruit_mass_counts_cells_outside_spheres() -> None:
    grid = VoxelGrid.from_bounds([0, 0, 0], [0.1, 0.1, 0.1], 0.05)  # 8 cells, centres at 0.025 / 0.075
    scene = Scene((Sphere(np.array([0.025, 0.025, 0.025]), 0.01),))
    p = np.zeros(8)
    p[0] = 0.75  # the cell whose centre is the sphere's centre
    p[7] = 0.25  # a far cell
    frac, n = off_fruit_mass(grid, p, 0.1, scene)
    assert n == 2
    assert_allclose(frac, 0.25)
    frac, n = off_fruit_mass(grid, p, 0.5, scene)  # the far cell is below 0.5 * max
    assert n == 1 and frac == 0.0
    assert math.isnan(off_fruit_mass(grid, np.zeros(8), 0.1, scene)[0])


def test_aggregate_pools_pairs(quick: tuple[ReproduceResult, Path, list]) -> None:
    result = quick[0]
    recs = [r for r in result.records if r.experiment == "noise-free" and r.label == "square/weighted"]
    recs = [r for r in recs if math.isclose(r.keep_threshold, result.config.keep_threshold)]
    a = aggregate_records(recs)
    d = np.concatenate([np.linalg.norm(r.paired_estimates - r.paired_truth, axis=1) for r in recs])
    assert_allclose(a.euclidean_mean, d.mean())
    assert_allclose(a.euclidean_max, d.max())
    assert a.misses == sum(r.metrics.misses for r in recs)
