"""The speed benchmark runs (no timing asserts: timings belong to the benchmark's JSON)."""

from __future__ import annotations

import json

import numpy as np
from typer.testing import CliRunner

from monovisual3d.bench.speed import format_markdown, run_speed
from monovisual3d.bench.update_cases import bench_scene, naive_update, paper_grid
from monovisual3d.cli import app
from monovisual3d.cli.bench import bench_app
from monovisual3d.methods.paper.engine.dense import paper_update_fused


def test_bench_speed_quick_cli(tmp_path):
    out = tmp_path / "speed.json"
    res = CliRunner().invoke(
        app,
        [
            "bench",
            "speed",
            "--quick",
            "--edges",
            "16",
            "--kernel",
            "square",
            "--refine-to",
            "0.008",
            "--no-scaling",
            "-o",
            str(out),
        ],
    )
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert {"cpu", "cores", "numpy", "numba"} <= set(data["meta"])
    methods = {r["method"] for r in data["rows"]}
    assert {"naive-python", "numpy", "numba", "numba-filter", "sparse"} <= methods
    for r in data["rows"]:
        assert r["per_view_ms"]["min"] <= r["per_view_ms"]["median"] <= r["per_view_ms"]["max"]
    assert data["sparse_fine"][0]["refine_to_mm"] == 8.0
    # every end-to-end row idle and with a busy core; the paper default against its numpy reference
    loads = {}
    for r in data["end_to_end"]:
        loads.setdefault(r["config"], set()).add(r["load"])
    assert loads and all(v == {"idle", "busy one core"} for v in loads.values())
    paper = data["paper_default_vs_numpy"]
    assert paper["default_backend"] == "numba" and paper["speedup"] > 0
    assert paper["objects"] == [6, 6] and paper["max_position_difference_m"] < 1e-3
    # the console says which load each end-to-end line is, and the speed-up the README's target is on
    lines = [ln for ln in res.stdout.splitlines() if ln.startswith("end-to-end localize")]
    assert lines and sum("busy one core" in ln for ln in lines) == len(lines) // 2
    assert any(ln.startswith(paper["config"]) and ln.rstrip().endswith("x") for ln in res.stdout.splitlines())
    assert bench_app.registered_commands  # the sub-app other benchmarks register on


def test_bench_speed_rejects_bad_options():
    res = CliRunner().invoke(app, ["bench", "speed", "--quick", "--kernel", "box"])
    assert res.exit_code == 2 and "--kernel" in res.output


def test_scaling_and_markdown():
    result = run_speed(quick=True, edges=(12,), kernels=("gaussian",), repeats=1, naive_cells=200, sparse_refine_to=0.01)
    md = format_markdown(result)
    assert "| numba | gaussian |" in md and "| views per update |" in md
    assert [r["views"] for r in result["scaling"]["views"]] == [1, 3]
    assert "| bayes (default) |" in md and "busy one core: ms median" in md
    assert "default (numba) vs numpy reference, same run" in md


def test_naive_loop_computes_the_same_update():
    camera, views = bench_scene()
    grid = paper_grid(views, 10)
    prior = np.full(grid.n_cells, 1.0 / grid.n_cells)
    total = naive_update(prior, grid, camera, views[0], "gaussian", 0.5, np.arange(grid.n_cells))
    fused = paper_update_fused(np.full(grid.n_cells, 1.0 / grid.n_cells), grid, camera, views[0], "gaussian", dtype=np.float64)
    np.testing.assert_allclose(prior / total, fused, rtol=1e-9, atol=1e-12)


def test_missing_torch_is_reported_not_silently_dropped(monkeypatch):
    import monovisual3d.methods.paper.engine.torch_backend as tb

    def no_torch():
        raise ImportError("torch is needed")

    monkeypatch.setattr(tb, "require_torch", no_torch)
    result = run_speed(
        quick=True, edges=(12,), kernels=("square",), repeats=1, methods=("numba", "torch"), scaling=False, sparse_refine_to=0.01
    )
    assert not any(r["method"].startswith("torch") for r in result["rows"])
    assert result["meta"]["skipped"] == ["torch: not importable, no torch rows (install the [gpu] extra to time it)"]
