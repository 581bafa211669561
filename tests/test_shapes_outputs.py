"""Shape fields of results (DetectedObject), truth files and evaluate."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from monovisual3d.cli import app
from monovisual3d.errors import InputError
from monovisual3d.metrics import evaluate
from monovisual3d.result import STANDARD_KEYS, DetectedObject, Result
from monovisual3d.truth import load_objects, objects_from_dict

CUCUMBER = {"position": [0.6, 0.0, 0.45], "semi_axes": [0.022, 0.022, 0.09], "quaternion_xyzw": [0, 0, 0, 1]}


def test_detected_object_writes_shape_fields() -> None:
    o = DetectedObject.from_ellipsoid([0.6, 0.0, 0.45], [0.022, 0.022, 0.09], [0, 0, 0, 1], 0.9, "spheroid")
    d = o.to_dict()
    assert d["shape"] == "spheroid"
    assert d["semi_axes"] == [0.022, 0.022, 0.09] and d["quaternion_xyzw"] == [0.0, 0.0, 0.0, 1.0]
    assert_allclose(d["radius"], np.cbrt(0.022 * 0.022 * 0.09))
    assert_allclose(d["volume_m3"], 4 / 3 * np.pi * 0.022 * 0.022 * 0.09)
    sphere = DetectedObject(np.zeros(3), 1.0, radius=0.03).to_dict()
    assert "shape" not in sphere and "semi_axes" not in sphere
    assert_allclose(sphere["volume_m3"], 4 / 3 * np.pi * 0.03**3)
    assert "volume_m3" not in DetectedObject(np.zeros(3), 1.0).to_dict()
    # a result with shapes reads back as truth-like objects with semi-axes
    text = Result([o, DetectedObject(np.ones(3), 1.0, radius=0.03)], "bayes").to_json()
    objs = objects_from_dict(json.loads(text))
    assert objs.from_result and objs.has_shapes
    assert_allclose(objs.semi_axes, [[0.022, 0.022, 0.09], [0.03, 0.03, 0.03]])


@pytest.mark.parametrize("key", sorted(STANDARD_KEYS))
def test_extra_cannot_shadow_standard_keys(key: str) -> None:
    with pytest.raises(ValueError, match=f"extra: key '{key}' would shadow"):
        DetectedObject(np.zeros(3), 1.0, extra={key: 1})
    o = DetectedObject(np.zeros(3), 1.0, extra={"radius_std": 0.001})
    assert o.to_dict()["radius_std"] == 0.001
    o.extra[key] = 2  # mutated after construction: caught when written
    with pytest.raises(ValueError, match="would shadow"):
        o.to_dict()


def test_detected_object_rejects_bad_shapes() -> None:
    with pytest.raises(ValueError, match="shape: got 'cube'"):
        DetectedObject(np.zeros(3), 1.0, shape="cube")
    with pytest.raises(ValueError, match="semi_axes: got"):
        DetectedObject(np.zeros(3), 1.0, semi_axes=np.array([0.01, 0.0, 0.02]))
    with pytest.raises(ValueError, match="quaternion_xyzw: got"):
        DetectedObject(np.zeros(3), 1.0, quaternion_xyzw=np.array([0, 0, 0, 2.0]))


def test_truth_semi_axes_and_volumes() -> None:
    objs = objects_from_dict({"objects": [CUCUMBER, {"position": [0, 0, 0], "radius": 0.03}, {"position": [1, 1, 1]}]})
    assert objs.has_shapes
    assert_allclose(objs.semi_axes[:2], [[0.022, 0.022, 0.09], [0.03, 0.03, 0.03]])
    assert np.isnan(objs.semi_axes[2]).all() and np.isnan(objs.volumes[2])
    assert_allclose(objs.volumes[0], 4 / 3 * np.pi * 0.022 * 0.022 * 0.09)
    assert not objects_from_dict({"objects": [{"position": [0, 0, 0], "radius": 0.03}]}).has_shapes
    with pytest.raises(InputError, match=r"objects\[0\].semi_axes: got \[0.02, -0.02, 0.09\], expected three positive"):
        objects_from_dict({"objects": [{**CUCUMBER, "semi_axes": [0.02, -0.02, 0.09]}]})
    with pytest.raises(InputError, match=r"objects\[0\].semi_axes"):
        objects_from_dict({"objects": [{**CUCUMBER, "semi_axes": [0.02, 0.09]}]})
    with pytest.raises(InputError, match=r"objects\[0\].volume_m3: got -1"):
        objects_from_dict({"objects": [{**CUCUMBER, "volume_m3": -1}]})


def test_evaluate_reports_sorted_semi_axis_and_volume_errors() -> None:
    truth = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    t_axes = np.array([[0.02, 0.02, 0.09], [0.03, 0.04, 0.05]])
    est = truth[::-1] + 0.001
    # the same ellipsoids, axes listed in another order, one 1 mm too long
    e_axes = np.array([[0.05, 0.03, 0.041], [0.09, 0.02, 0.02]])
    m = evaluate(est, truth, truth_semi_axes=t_axes, estimate_semi_axes=e_axes)
    assert m.semi_axis_error_mean == pytest.approx(0.001 / 6, rel=1e-9)
    assert m.semi_axis_error_max == pytest.approx(0.001, rel=1e-9)
    dv = 4 / 3 * np.pi * 0.03 * 0.05 * 0.001
    assert m.volume_error_mean == pytest.approx(dv / 2, rel=1e-9)
    assert m.volume_error_pct_mean == pytest.approx(100 * (0.001 / 0.04) / 2, rel=1e-9)
    assert evaluate(est, truth).semi_axis_error_mean is None
    nan_rows = evaluate(est, truth, truth_semi_axes=t_axes, estimate_semi_axes=np.full((2, 3), np.nan))
    assert nan_rows.volume_error_mean is None


def test_cli_evaluate_prints_shape_errors(tmp_path) -> None:
    (tmp_path / "truth.json").write_text(json.dumps({"objects": [CUCUMBER]}))
    est = Result([DetectedObject.from_ellipsoid([0.601, 0, 0.45], [0.022, 0.022, 0.092], [0, 0, 0, 1], 1.0, "spheroid")], "bayes")
    est.to_json(tmp_path / "est.json")
    r = CliRunner().invoke(
        app, ["evaluate", str(tmp_path / "est.json"), str(tmp_path / "truth.json"), "-o", str(tmp_path / "m.json")]
    )
    assert r.exit_code == 0, r.output
    assert "semi-axis error (mm)" in r.output and "volume error (%)" in r.output
    m = json.loads((tmp_path / "m.json").read_text())
    assert m["semi_axis_error_max"] == pytest.approx(0.002, rel=1e-9)
    sphere_truth = tmp_path / "sphere.json"
    sphere_truth.write_text(json.dumps({"objects": [{"position": [0.6, 0, 0.45], "radius": 0.03}]}))
    r = CliRunner().invoke(app, ["evaluate", str(tmp_path / "est.json"), str(sphere_truth)])
    assert r.exit_code == 0 and "semi-axis" not in r.output
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"objects": [{**CUCUMBER, "semi_axes": [0, 1, 1]}]}))
    r = CliRunner().invoke(app, ["evaluate", str(tmp_path / "est.json"), str(bad)])
    assert r.exit_code == 2 and "semi_axes" in r.output
    assert load_objects(tmp_path / "est.json").has_shapes


def test_objects_schema_accepts_results_and_truth_with_shapes() -> None:
    from importlib import resources

    jsonschema = pytest.importorskip("jsonschema")
    from monovisual3d.sim import shapes_scene, simulate

    schema = json.loads((resources.files("monovisual3d") / "schemas" / "objects.schema.json").read_text())
    validator = jsonschema.Draft202012Validator(schema)
    o = DetectedObject.from_ellipsoid([0.6, 0, 0.45], [0.02, 0.02, 0.09], [0, 0, 0, 1], 0.9, "spheroid", associations={0: 1})
    o.covariance = np.eye(3) * 1e-6
    o.extra["radius_std"] = 0.001
    result = json.loads(Result([o, DetectedObject(np.ones(3), 0.5, radius=0.03)], "bayes").to_json())
    assert not list(validator.iter_errors(result))
    _, truth = simulate(shapes_scene("mixed", rng=0), rng=0)
    assert not list(validator.iter_errors(json.loads(json.dumps(truth))))
    bad = {"objects": [{**result["objects"][0], "shape": "cube"}]}
    assert [e.message for e in validator.iter_errors(bad)] == ["'cube' is not one of ['sphere', 'spheroid', 'ellipsoid']"]
    assert list(validator.iter_errors({"objects": [{"position": [0, 0, 0], "semi_axes": [0.1, 0, 0.1]}]}))
