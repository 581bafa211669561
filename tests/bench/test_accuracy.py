"""The accuracy benchmark runs, pools honestly and checks its targets."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.bench.accuracy import (
    check_targets,
    conditions,
    crlb_rms_sq,
    cut_crlb_rms_sq,
    format_markdown,
    run_accuracy,
    save,
)
from monovisual3d.errors import InputError
from monovisual3d.geometry.bounds import cut_edges
from monovisual3d.geometry.ellipsoid import ellipsoid_bbox
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import default_camera, greenhouse_scene, paper_scene
from monovisual3d.sim.simulate import simulate_views


@pytest.fixture(scope="module")
def results():
    return run_accuracy(quick=True, methods=("bayes", "paper"), only=("paper-clean", "n-fruit-2"))


def test_runs_and_reports_every_method(results, tmp_path):
    clean = results["results"]["paper-clean"]["methods"]
    assert set(clean) == {"bayes", "paper"}
    assert clean["bayes"]["n_truth"] == 6
    # the default method finds every fruit of the noise-free paper scene to sub-millimetre, the baseline does not
    assert clean["bayes"]["recall"] == 1.0 and clean["bayes"]["precision"] == 1.0
    assert clean["bayes"]["mean_mm"] < 1.5
    assert clean["paper"]["mean_mm"] > clean["bayes"]["mean_mm"]
    assert clean["bayes"]["radius_mm"] < 1.0
    assert clean["paper"]["radius_mm"] is None  # the paper method estimates no size
    md = format_markdown(results)
    assert "| paper-clean | bayes |" in md and "| n-fruit-2 | paper |" in md
    out = tmp_path / "acc.json"
    save(results, str(out))
    assert json.loads(out.read_text())["results"]["n-fruit-2"]["methods"]["bayes"]["runs"] >= 1


def test_target_check_reads_the_measured_values(results):
    rows = {(c, m): (v, met) for c, m, v, _, _, met in check_targets(results)}
    v, met = rows[("paper-clean", "mean_mm")]
    assert np.isclose(v, results["results"]["paper-clean"]["methods"]["bayes"]["mean_mm"])
    assert met == (v <= 1.5)


def test_conditions_cover_the_issue_list():
    names = {c.name for c in conditions()}
    assert {"paper-clean", "paper-noise", "greenhouse", "pose-error"} <= names
    assert {f"n-fruit-{k}" for k in (1, 2, 4, 6, 10)} <= names
    by_name = {c.name: c for c in conditions()}
    assert by_name["greenhouse-clutter"].noise.false_positive_rate > 0
    assert by_name["greenhouse-noise"].noise.box_sigma > 0 and by_name["greenhouse-noise"].noise.false_positive_rate == 0
    # the Cramer-Rao bound: from full boxes without occluders, from the cut visible boxes with them
    assert {c.name for c in conditions() if c.crlb == "full"} == {"paper-noise", "shapes-noise"}
    assert {c.name for c in conditions() if c.crlb == "cut"} == {"greenhouse-noise", "greenhouse-clutter"}
    assert {"shapes-clean", "shapes-noise", "shapes-occluded"} <= names


def test_bad_names_are_rejected():
    with pytest.raises(InputError, match="methods"):
        run_accuracy(quick=True, methods=("nope",))
    with pytest.raises(InputError, match="only"):
        run_accuracy(quick=True, only=("nope",))


def test_cli_bench_accuracy_prints_the_table(tmp_path):
    from typer.testing import CliRunner

    from monovisual3d.cli import app

    out = tmp_path / "acc.json"
    res = CliRunner().invoke(app, ["bench", "accuracy", "--methods", "bayes", "--only", "n-fruit-1", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "| n-fruit-1 | bayes |" in res.output
    assert json.loads(out.read_text())["results"]["n-fruit-1"]["methods"]["bayes"]["recall"] == 1.0
    bad = CliRunner().invoke(app, ["bench", "accuracy", "--methods", "nope"])
    assert bad.exit_code == 2 and "methods" in bad.output


def test_cut_bound_equals_the_full_bound_without_occluders():
    scene = paper_scene()
    svs = simulate_views(scene, noise=NoiseModel.paper(), rng=3)
    # the rendered boxes lie within a pixel of the exact ones, so the two bounds agree to about a percent
    assert_allclose(cut_crlb_rms_sq(scene, svs, 0.05), crlb_rms_sq(scene, svs, 0.05), rtol=0.03)


def test_false_positives_add_nothing_and_leaves_cut_edges():
    scene = greenhouse_scene(rng=4)
    svs = simulate_views(scene, noise=NoiseModel.paper(), rng=4)
    bound = cut_crlb_rms_sq(scene, svs, 0.05)
    assert len(bound) == len(scene.fruits) and np.all(np.isfinite(bound))
    # false-positive boxes (source -1) appended to every view leave each fruit's bound as it was
    fp = np.array([[10.0, 10.0, 60.0, 60.0], [300.0, 200.0, 340.0, 260.0], [500.0, 400.0, 600.0, 470.0]])
    cluttered = [
        replace(sv, boxes_xyxy=np.concatenate([sv.boxes_xyxy, fp]), source=np.concatenate([sv.source, [-1, -1, -1]]))
        for sv in svs
    ]
    assert_allclose(cut_crlb_rms_sq(scene, cluttered, 0.05), bound, rtol=1e-12)
    # the leaves cut some fruit's edges in this scene
    cam = default_camera()
    n_cut = 0
    for f, fruit in enumerate(scene.fruits):
        e = fruit.ellipsoid
        for sv in svs:
            if f in sv.source:
                full = ellipsoid_bbox(cam, sv.T_base_optical_true, e.centre_base, e.semi_axes, e.rotation, clip=False)
                n_cut += int(cut_edges(full, sv.rendering.boxes_xyxy[f]).sum())
    assert n_cut > 0
