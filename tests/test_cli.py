"""The CLI end to end: localize and evaluate on the shipped example, exit codes, one-line errors, --quiet."""

from __future__ import annotations

import json
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from cli_checks import assert_one_line_error
from monovisual3d import evaluate as evaluate_fn
from monovisual3d.cli import app
from monovisual3d.errors import InputWarning
from monovisual3d.examples import example_session_path, example_truth_path

#: Coarse grid: keeps the CLI tests fast; the example's sphere is still found within 20 mm at this resolution.
FAST = ["--method", "paper", "--resolution", "0.02"]


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def test_localize_writes_documented_json(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "estimates.json"
    result = runner.invoke(app, ["localize", str(example_session_path()), *FAST, "--output", str(out)])
    assert result.exit_code == 0, result.output
    assert "Localised objects" in result.stdout and "x (mm)" in result.stdout
    assert f"wrote {out}" in result.stdout.replace("\n", "")
    data = json.loads(out.read_text())
    assert {"objects", "method", "grid", "timing_s"} <= set(data)
    assert data["method"] == "paper"
    assert data["grid"]["resolution_m"] == 0.02
    assert data["timing_s"]["total"] >= 0
    truth = json.loads(example_truth_path().read_text())["objects"][0]["position"]
    assert len(data["objects"]) == 1
    assert isinstance(data["objects"][0]["score"], float)
    assert_allclose(data["objects"][0]["position"], truth, atol=0.02)


def test_localize_options_reach_the_library(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "estimates.json"
    args = ["localize", str(example_session_path()), *FAST, "--kernel", "square", "--centre", "geometric", "--k", "2"]
    result = runner.invoke(app, [*args, "--sigma-fraction", "0.3333", "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    data = json.loads(out.read_text())
    assert data["config"]["kernel"] == "square" and data["config"]["centre"] == "geometric"
    assert data["config"]["k"] == 2 and data["config"]["sigma_fraction"] == 0.3333
    assert len(data["objects"]) == 2


def test_quiet_prints_json_only(runner: CliRunner) -> None:
    result = runner.invoke(app, ["localize", str(example_session_path()), *FAST, "--quiet"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)  # nothing but the JSON on stdout
    assert data["method"] == "paper" and len(data["objects"]) == 1
    assert "Localised objects" not in result.stdout


def test_quiet_with_output_prints_nothing(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    result = runner.invoke(app, ["localize", str(example_session_path()), *FAST, "-q", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert result.stdout.strip() == ""
    assert json.loads(out.read_text())["objects"]


def test_evaluate_prints_the_metric_table(runner: CliRunner, tmp_path: Path) -> None:
    est = tmp_path / "estimates.json"
    assert runner.invoke(app, ["localize", str(example_session_path()), *FAST, "-q", "-o", str(est)]).exit_code == 0
    metrics_path = tmp_path / "metrics.json"
    result = runner.invoke(app, ["evaluate", str(est), str(example_truth_path()), "-o", str(metrics_path)])
    assert result.exit_code == 0, result.output
    for row in ("Euclidean mean (mm)", "MAE (mm)", "MSE (mm^2)", "RMSE (mm)", "MAPE (%)", "recall", "misses / false pos."):
        assert row in result.stdout
    position = np.array(json.loads(est.read_text())["objects"][0]["position"])
    truth = np.array(json.loads(example_truth_path().read_text())["objects"][0]["position"])
    expected = evaluate_fn(position, truth, truth_radii=[0.03])
    assert f"{1000 * expected.euclidean_mean:.2f}" in result.stdout
    assert f"{1000 * expected.rmse:.2f}" in result.stdout
    written = json.loads(metrics_path.read_text())
    assert written["euclidean_mean"] == pytest.approx(expected.euclidean_mean, rel=1e-12)
    assert (written["true_positives"], written["misses"], written["false_positives"]) == (1, 0, 0)
    assert "swapped" not in result.output


def test_evaluate_warns_when_the_arguments_look_swapped(runner: CliRunner, tmp_path: Path) -> None:
    est = tmp_path / "estimates.json"
    assert runner.invoke(app, ["localize", str(example_session_path()), *FAST, "-q", "-o", str(est)]).exit_code == 0
    with pytest.warns(InputWarning, match=r"estimates.json is a localize result and .*truth.json is not: arguments swapped\?"):
        result = runner.invoke(app, ["evaluate", str(example_truth_path()), str(est)])
    assert result.exit_code == 0, result.output


def test_missing_session_file(runner: CliRunner, tmp_path: Path) -> None:
    missing = tmp_path / "nope.json"
    assert_one_line_error(runner.invoke(app, ["localize", str(missing), *FAST]), f"{missing}: file not found")


def test_bad_session_names_file_and_field(runner: CliRunner, tmp_path: Path, valid_session: dict[str, Any]) -> None:
    valid_session["views"][0]["pose"]["quaternion_xyzw"] = [0.0, 0.0, 0.0, 2.0]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(valid_session))
    assert_one_line_error(
        runner.invoke(app, ["localize", str(path), *FAST]), f"{path}: views[0].pose.quaternion_xyzw: norm 2, expected 1"
    )


def test_error_text_with_brackets_is_printed_verbatim(runner: CliRunner, tmp_path: Path, valid_session: dict[str, Any]) -> None:
    """Messages contain JSON paths and lists such as [x1, y1, x2, y2]; they must not be eaten as console markup."""
    del valid_session["views"][0]["detections"][0]["bbox_xyxy"]
    path = tmp_path / "bad.yaml"
    path.write_text(json.dumps(valid_session))  # JSON is valid YAML
    assert_one_line_error(
        runner.invoke(app, ["localize", str(path), *FAST]),
        f"{path}: views[0].detections[0].bbox_xyxy: missing field, expected [x1, y1, x2, y2] in pixels",
    )


def test_malformed_json_session(runner: CliRunner, tmp_path: Path) -> None:
    path = tmp_path / "broken.json"
    path.write_text('{"camera": ')
    assert_one_line_error(runner.invoke(app, ["localize", str(path), *FAST]), f"{path}: not valid JSON at line 1")


@pytest.mark.parametrize(
    ("option", "fragment"),
    [
        (["--kernel", "box"], "error: --kernel: got 'box'"),
        (["--centre", "middle"], "error: --centre: got 'middle'"),
        (["--k", "several"], "error: --k: got 'several'"),
        (["--resolution", "0.0001"], "--resolution 0.00"),
        (["--method", "magic"], "error: --method: got 'magic'"),
        (["--method", "bayes", "--accept", "inf"], "error: --accept: got inf, expected a finite number of nats"),
    ],
)
def test_bad_options_exit_2(runner: CliRunner, option: list[str], fragment: str) -> None:
    args = ["localize", str(example_session_path()), "--method", "paper", "--resolution", "0.02", *option]
    assert_one_line_error(runner.invoke(app, args), fragment)


def test_evaluate_bad_inputs(runner: CliRunner, tmp_path: Path) -> None:
    est = tmp_path / "est.json"
    est.write_text(json.dumps({"objects": [{"position": [0.6, 0.0]}]}))
    assert_one_line_error(
        runner.invoke(app, ["evaluate", str(est), str(example_truth_path())]),
        f"{est}: objects[0].position: expected 3 numbers, got 2",
    )
    empty_truth = tmp_path / "truth.json"
    empty_truth.write_text(json.dumps({"objects": []}))
    est.write_text(json.dumps({"objects": [{"position": [0.6, 0.0, 0.4]}]}))
    assert_one_line_error(
        runner.invoke(app, ["evaluate", str(est), str(empty_truth)]),
        f"{empty_truth}: objects: empty, expected at least one object",
    )
    assert_one_line_error(runner.invoke(app, ["evaluate", str(tmp_path / "x.json"), str(empty_truth)]), "file not found")


def test_console_scripts_are_registered() -> None:
    scripts = {ep.name: ep.value for ep in entry_points(group="console_scripts") if ep.name in ("monovisual3d", "mv3d")}
    assert scripts == {"monovisual3d": "monovisual3d.cli:main", "mv3d": "monovisual3d.cli:main"}


def test_paper_only_options_are_rejected_for_bayes(runner: CliRunner) -> None:
    result = runner.invoke(app, ["localize", str(example_session_path()), "--kernel", "square"])
    assert result.exit_code == 2
    assert "--kernel: not an option of --method bayes (it applies to --method paper)" in result.output
    assert "Traceback" not in result.output


def test_evaluate_rejects_a_non_positive_gate(runner: CliRunner) -> None:
    result = runner.invoke(app, ["evaluate", str(example_truth_path()), str(example_truth_path()), "--gate", "-1"])
    assert result.exit_code == 2 and "--gate" in result.output
