"""What a newcomer sees on the console (issue 21): wrong kinds of file named, warnings after the table,
--strict, shape columns, metric definitions, the next-view listing, batch wording, and user text
with rich markup (``[/x]``, ``[bold]``) printed literally (issue 23)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from cli_checks import assert_one_line_error
from monovisual3d import DetectedObject, Result, load_session
from monovisual3d.cli import app
from monovisual3d.cli._app import console
from monovisual3d.cli.core import METRIC_NOTE, print_objects
from monovisual3d.completeness import incomplete_reasons
from monovisual3d.examples import example_session_path, example_truth_path
from monovisual3d.file_kinds import kind_of, wrong_kind

FAST = ["--method", "paper", "--resolution", "0.02"]
#: Folder names with rich markup in them: they must print as typed.
MARKUP_DIRS = ("b[/x]", "[bold]")


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def _example() -> dict[str, Any]:
    return json.loads(example_session_path().read_text())


def _write(path: Path, data: Any) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    return path


# ------------------------------------------------------------------ wrong kind of file
@pytest.mark.parametrize(
    ("data", "what"),
    [
        (
            {"objects": [], "views": [], "noise": {}, "scene": "paper"},
            "this is a truth file (written by simulate), not a session",
        ),
        ({"objects": [], "method": "bayes", "config": {}, "grid": {}}, "this is a result file (written by localize --output)"),
        ({"name": "paper", "objects": [], "occluders": []}, "this is a scene file (written by simulate)"),
        ({"index": 0, "ranking": [], "done": False, "pose": {}}, "this is a next-view plan"),
        ({"n_sessions": 1, "n_ok": 1, "n_error": 0, "n_fruit": 3}, "this is a batch summary"),
        ({"poses": [{"position": [0, 0, 0]}]}, "this is a list of poses"),
        ([{"position": [0, 0, 0], "target": [1, 0, 0]}], "this is a list of poses"),
        ({"euclidean_mean": 0.1, "recall": 1.0, "precision": 1.0, "n_truth": 1}, "this is a metrics file"),
    ],
)
def test_localize_names_the_kind_of_file_given_instead_of_a_session(
    runner: CliRunner, tmp_path: Path, data: Any, what: str
) -> None:
    path = _write(tmp_path / "file.json", data)
    line = assert_one_line_error(runner.invoke(app, ["localize", str(path)]), f"{path}: {what}")
    assert "unknown field" not in line


def test_simulated_truth_and_result_files_are_recognised(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "result.json"
    assert runner.invoke(app, ["localize", str(example_session_path()), *FAST, "-o", str(out), "-q"]).exit_code == 0
    assert_one_line_error(runner.invoke(app, ["localize", str(out)]), "result file", "give it to evaluate")
    truth = {**json.loads(example_truth_path().read_text()), "noise": {}, "scene": "paper"}  # as simulate writes it
    assert_one_line_error(runner.invoke(app, ["localize", str(_write(tmp_path / "truth.json", truth))]), "truth file", "evaluate")


def test_evaluate_given_a_session_says_so(runner: CliRunner) -> None:
    result = runner.invoke(app, ["evaluate", str(example_session_path()), str(example_truth_path())])
    assert_one_line_error(result, "this is a session file", "not a result or truth file", "monovisual3d localize")


def test_kinds_are_recognised_only_for_wrong_files() -> None:
    assert kind_of(_example()) == "session"
    assert wrong_kind(_example(), "session") is None
    assert wrong_kind({"objects": [{"position": [0, 0, 0]}]}, "objects") is None
    assert wrong_kind({"something": 1}, "session") is None
    assert kind_of([1, 2]) is None


# ------------------------------------------------------------------ warnings after the table, --strict
def _disagreeing_session(tmp_path: Path) -> Path:
    """The example's three views with the second and third views' boxes moved to unrelated corners."""
    data = _example()
    data["views"][1]["detections"][0]["bbox_xyxy"] = [10, 10, 40, 40]
    data["views"][2]["detections"][0]["bbox_xyxy"] = [590, 420, 630, 470]
    return _write(tmp_path / "disagree.json", data)


def test_empty_result_says_why_on_the_console_and_strict_exits_1(runner: CliRunner, tmp_path: Path) -> None:
    session, out = _disagreeing_session(tmp_path), tmp_path / "r.json"
    result = runner.invoke(app, ["localize", str(session), "-o", str(out)])
    assert result.exit_code == 0, result.output
    warning_lines = [line for line in result.stderr.splitlines() if line.startswith("warning: ")]
    assert len(warning_lines) == 1, result.stderr
    assert "no object found" in warning_lines[0] and "3 views have detections" in warning_lines[0]
    assert json.loads(out.read_text())["warnings"], "the JSON keeps its warnings"
    strict = runner.invoke(app, ["localize", str(session), "--strict", "-q"])
    assert strict.exit_code == 1
    assert json.loads(strict.stdout)["objects"] == []  # --quiet still prints the result, then exits 1
    assert "warning: no object found" in strict.stderr


def test_a_stray_box_in_one_view_is_no_alarm(runner: CliRunner, tmp_path: Path) -> None:
    """A false positive in one view cannot be a fruit the method missed (no other view's left-over box meets its ray):
    no warning, and --strict exits 0; boxes two views leave over that could be one fruit are reported (below)."""
    data = _example()
    data["views"][0]["detections"].append({"bbox_xyxy": [10.0, 10.0, 40.0, 40.0]})  # a false positive in one view
    session = _write(tmp_path / "fp.json", data)
    result = runner.invoke(app, ["localize", str(session)])
    assert result.exit_code == 0, result.output
    assert "│ 0 │" in result.stdout  # the sphere is still found
    assert "associated to no object" not in result.stderr
    assert runner.invoke(app, ["localize", str(session), "--strict"]).exit_code == 0


@pytest.mark.filterwarnings("ignore:3 views have detections but no object:monovisual3d.errors.InputWarning")
def test_batch_reports_incomplete_sessions_and_strict_exits_1(runner: CliRunner, tmp_path: Path) -> None:
    _write(tmp_path / "in" / "good" / "session.json", _example())
    bad = json.loads(_disagreeing_session(tmp_path).read_text())
    _write(tmp_path / "in" / "bad" / "session.json", bad)
    args = ["batch", str(tmp_path / "in"), "--workers", "0", "-q"]
    result = runner.invoke(app, [*args, "-o", str(tmp_path / "out1")])
    assert result.exit_code == 0, result.output
    (line,) = [x for x in result.stderr.splitlines() if x.startswith("warning: ")]
    assert line.startswith("warning: 1 session(s) with an incomplete result (sessions.csv, column warnings), the first: bad")
    assert "no object found" in line
    strict = runner.invoke(app, [*args, "-o", str(tmp_path / "out2"), "--strict"])
    assert strict.exit_code == 1


def test_incomplete_reasons_in_python() -> None:
    session = load_session(example_session_path())
    found = Result([DetectedObject(np.zeros(3), 1.0, associations={0: 0, 1: 0, 2: 0})], "bayes")
    assert incomplete_reasons(session, found) == []
    # the sphere's boxes of views 1 and 2 left over: their rays meet as one fruit's, a fruit the result misses
    partial = Result([DetectedObject(np.zeros(3), 1.0, associations={0: 0})], "bayes")
    assert "2 of 3 boxes are associated to no object (view 1: box 0; view 2: box 0)" in incomplete_reasons(session, partial)[0]
    assert "a lower --accept" in incomplete_reasons(session, partial)[0]
    # three boxes left over in one view: more than false positives leave, the views disagree
    many = _example()
    many["views"][0]["detections"] += [{"bbox_xyxy": [10.0 + 40 * k, 10.0, 40.0 + 40 * k, 40.0]} for k in range(3)]
    whole = Result([DetectedObject(np.zeros(3), 1.0, associations={0: 0, 1: 0, 2: 0})], "bayes")
    assert "3 of 6 boxes are associated to no object (view 0: boxes 1, 2, 3)" in incomplete_reasons(load_session(many), whole)[0]
    # one box left over, in one view: a fruit seen once or a false positive, nothing more to localise
    assert incomplete_reasons(session, Result([DetectedObject(np.zeros(3), 1.0, associations={0: 0, 1: 0})], "bayes")) == []
    # the advice names only options of the method that ran: quadric has no --accept, and needs 3 views per object
    partial_quadric = Result([DetectedObject(np.zeros(3), 1.0, associations={0: 0})], "quadric")
    (quadric_reason,) = incomplete_reasons(session, partial_quadric)
    assert "--accept" not in quadric_reason and "--min-views" in quadric_reason
    no_associations = Result([DetectedObject(np.zeros(3), 1.0)], "paper")  # a method that does not associate
    assert incomplete_reasons(session, no_associations) == []
    (empty,) = incomplete_reasons(session, Result([], "paper"))
    assert "no object found although 3 views have boxes" in empty and "try" in empty
    (reason,) = incomplete_reasons(session, Result([], "bayes", warnings=["the method's reason"]))
    assert reason == "no object found: the method's reason"


# ------------------------------------------------------------------ tables
def test_shape_columns_only_when_an_object_is_not_a_sphere() -> None:
    sphere = DetectedObject(np.array([0.5, 0.0, 0.4]), 12.0, radius=0.03)
    spheroid = DetectedObject.from_ellipsoid([0.6, 0.1, 0.4], [0.0405, 0.0405, 0.0473], [0, 0, 0, 1], 11.0, "spheroid")
    with console.capture() as plain_table:
        print_objects(Result([sphere], "bayes"))
    assert "shape" not in plain_table.get()
    with console.capture() as shaped:
        print_objects(Result([sphere, spheroid], "bayes"))
    text = shaped.get()
    assert "shape" in text and "semi-axes (mm)" in text
    assert "spheroid" in text and "40.5/40.5/47.3" in text


def test_evaluate_defines_its_metrics_under_the_table_and_in_help(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    runner.invoke(app, ["localize", str(example_session_path()), *FAST, "-o", str(out), "-q"])
    result = runner.invoke(app, ["evaluate", str(out), str(example_truth_path())])
    assert result.exit_code == 0, result.output
    assert METRIC_NOTE in result.stdout
    assert "over the x, y and z errors separately" in METRIC_NOTE and "3D distance" in METRIC_NOTE
    help_text = " ".join(runner.invoke(app, ["evaluate", "--help"]).stdout.split())
    assert "MAE, MSE, RMSE, MAPE: over the x, y and z errors separately" in help_text
    assert "RMSE = sqrt(mean squared 3D distance / 3)" in help_text


def test_next_view_lists_every_chosen_pose_with_the_gain_unit(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "plan.json"
    args = ["next-view", str(example_session_path()), "--candidates", "cap:12", "--count", "3", "-o", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    plan = json.loads(out.read_text())
    assert len(plan["indices"]) == 3
    assert "gain (mm)" in result.stdout and "expected drop of the objects' RMS position error, mm" in result.stdout
    for pick, (index, pose, gain) in enumerate(zip(plan["indices"], plan["poses"], plan["gains"], strict=True), start=1):
        x = pose["position"][0]
        row = next(line for line in result.stdout.splitlines() if line.startswith(f"│    {pick} │"))
        assert f" {index} │" in row and f"{x:.3f}" in row and f"{gain:.2f}" in row


# ------------------------------------------------------------------ batch
def test_batch_on_an_empty_folder_prints_the_error_alone(runner: CliRunner, tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    result = runner.invoke(app, ["batch", str(tmp_path / "empty"), "-o", str(tmp_path / "out"), "--workers", "0"])
    assert_one_line_error(result, "no session.json")
    assert result.stdout == "", "no progress bar before the inputs are checked"


def test_batch_piped_output_does_not_wrap_and_says_processes(runner: CliRunner, tmp_path: Path) -> None:
    deep = tmp_path / ("a-long-folder-name-" * 4) / "s1"
    _write(deep / "session.json", _example())
    out = tmp_path / ("another-long-output-folder-" * 3)
    result = runner.invoke(app, ["batch", str(deep.parent), "-o", str(out), "--workers", "0", *_batch_fast()])
    assert result.exit_code == 0, result.output
    summary = f"1 ok, 0 failed, 1 fruit; wrote {out}/fruit.parquet, sessions.parquet (+ .csv), summary.json"
    assert summary in result.stdout.splitlines(), result.stdout
    assert "thread" not in result.stdout


def test_batch_help_and_announcement_use_one_word_for_workers() -> None:
    from monovisual3d.cli.batch import _announcer

    class P:
        workers, total, skipped, dashboard = 2, 5, 0, None

    with console.capture() as cap:
        _announcer(None)(P())
    assert cap.get().strip() == "running 5 session(s) on 2 worker process(es)"


# ------------------------------------------------------------------ rich markup in user text
@pytest.fixture
def markup_dir(tmp_path: Path) -> Path:
    d = tmp_path.joinpath(*MARKUP_DIRS)
    d.mkdir(parents=True)
    data = _example()
    data["views"][0]["detections"][0]["label"] = "[bold]tomato[/x]"
    _write(d / "session.json", data)
    (d / "truth.json").write_text(example_truth_path().read_text())
    return d


def _literal(result: Any, *texts: str) -> None:
    assert "MarkupError" not in repr(result.exception) and "Traceback" not in result.output, result.output
    flat = result.output.replace("\n", "")
    for text in texts:
        assert text in flat, result.output


def test_markup_in_paths_and_labels_prints_literally(runner: CliRunner, markup_dir: Path) -> None:
    session, res = markup_dir / "session.json", markup_dir / "r.json"
    r = runner.invoke(app, ["localize", str(session), *FAST, "-o", str(res)])
    assert r.exit_code == 0
    _literal(r, f"wrote {res}")
    r = runner.invoke(app, ["evaluate", str(res), str(markup_dir / "truth.json")])
    assert r.exit_code == 0
    _literal(r, "r.json")
    r = runner.invoke(app, ["next-view", str(session), "--candidates", "cap:8", "-o", str(markup_dir / "plan.json")])
    assert r.exit_code == 0
    _literal(r, f"wrote {markup_dir / 'plan.json'}")
    r = runner.invoke(app, ["simulate", "-o", str(markup_dir / "sim"), "--no-images"])
    assert r.exit_code == 0
    _literal(r, f"to {markup_dir / 'sim'}")
    r = runner.invoke(app, ["batch", str(markup_dir), "-o", str(markup_dir / "out"), "--workers", "0", *_batch_fast()])
    assert r.exit_code == 0
    _literal(r, f"wrote {markup_dir / 'out'}/fruit.parquet")


def _batch_fast() -> list[str]:
    return ["--method", "paper", "--option", "resolution=0.02"]


def test_markup_in_view_output_path(runner: CliRunner, markup_dir: Path) -> None:
    pytest.importorskip("plotly")
    out = markup_dir / "scene.html"
    r = runner.invoke(app, ["view", str(markup_dir / "session.json"), "-o", str(out)])
    assert r.exit_code == 0, r.output
    _literal(r, f"wrote {out}")


def test_markup_in_a_failed_batch_session_prints_literally(runner: CliRunner, markup_dir: Path) -> None:
    broken = markup_dir / "[red]broken[/x]" / "session.json"
    broken.parent.mkdir(parents=True)
    broken.write_text('{"camera": {}, "views": [], "[/x]": 1}')
    r = runner.invoke(app, ["batch", str(markup_dir), "-o", str(markup_dir / "out"), "--workers", "0", *_batch_fast()])
    assert r.exit_code == 1, r.output
    _literal(r, "failed: [red]broken[/x]", "[/x]: unknown field")


def test_markup_in_errors_and_session_keys_prints_literally(runner: CliRunner, markup_dir: Path, tmp_path: Path) -> None:
    missing = markup_dir / "nope[/x].json"
    _literal(runner.invoke(app, ["localize", str(missing)]), f"error: {missing}: file not found")
    data = _example()
    data["[/x]"] = 1
    bad = _write(markup_dir / "key.json", data)
    assert_one_line_error(runner.invoke(app, ["localize", str(bad)]), "[/x]: unknown field")
    data = _example()
    data["views"][0]["detections"][0]["[bold]"] = 1
    bad = _write(tmp_path / "detection-key.json", data)
    assert_one_line_error(runner.invoke(app, ["localize", str(bad)]), "views[0].detections[0].[bold]: unknown field")


@pytest.mark.parametrize(
    ("name", "content", "expected"),
    [
        ("sessions.csv", b"session,status\nruns/a,ok\n", "this looks like a CSV table"),
        ("fruit.parquet", b"PAR1\x15\x04\x15\xff\xfe", "this looks like a Parquet table"),
        ("scene.png", b"\x89PNG\r\n\x1a\n\x00\xff\xfe", "this looks like an image"),
    ],
)
def test_a_table_or_image_in_place_of_a_session_says_what_it_is(tmp_path, name, content, expected):
    path = tmp_path / name
    path.write_bytes(content)
    res = CliRunner().invoke(app, ["localize", str(path)])
    assert res.exit_code == 2
    assert expected in res.stderr and len(res.stderr.strip().splitlines()) == 1


def _commands(group: Any, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    """Every command path of the CLI (``("bench", "real")``, ...)."""
    out = []
    for name, cmd in group.commands.items():
        path = (*prefix, name)
        out.append(path)
        if hasattr(cmd, "commands"):
            out += _commands(cmd, path)
    return out


def test_every_help_is_plain_text(runner: CliRunner) -> None:
    """``--help`` shows no reST or Sphinx markup (the help is built from docstrings)."""
    import typer.main

    paths = _commands(typer.main.get_command(app))
    assert ("bench", "real") in paths and ("localize",) in paths
    for path in paths:
        res = runner.invoke(app, [*path, "--help"])
        assert res.exit_code == 0, (path, res.output)
        for mark in ("``", ":mod:`", ":func:`", ":attr:`", ":class:`", ":data:`", ":meth:`"):
            assert mark not in res.stdout, (path, mark)


def test_help_lists_a_newcomers_commands_first(runner: CliRunner) -> None:
    out = runner.invoke(app, ["--help"]).stdout
    listed = [ln.split()[0] for ln in out.split("Commands:", 1)[1].splitlines() if ln.startswith("  ") and ln.strip()]
    assert listed[:3] == ["demo", "localize", "evaluate"] and listed[-1] == "bench", listed


def test_method_options_show_their_defaults(runner: CliRunner) -> None:
    out = " ".join(runner.invoke(app, ["localize", "--help"], env={"COLUMNS": "250"}).stdout.split())  # unwrapped
    assert "manipulator reach R" in out and "[default: 0.6]" in out
    assert "memory budget of the call [default: 2GiB]" in out
    assert "--shape <str> bayes method: object model" in out  # the Python type is the option's, not in the text


def test_a_fresh_process_piping_its_table_does_not_wrap_it(tmp_path: Path) -> None:
    """The console is made on first print (rich is imported then): made mid-command in a fresh process, it is still
    as wide as :data:`monovisual3d.cli._app.PIPE_WIDTH` when its output is a pipe, whatever the terminal says."""
    import os
    import subprocess
    import sys

    out = tmp_path / "result.json"
    cmd = [sys.executable, "-m", "monovisual3d.cli", "localize", str(example_session_path()), "-o", str(out)]
    res = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "COLUMNS": "30"})
    assert res.returncode == 0, res.stderr
    obj = json.loads(out.read_text())["objects"][0]
    x, y, z = (f"{1000 * v:.1f}" for v in obj["position"])
    row = [line for line in res.stdout.splitlines() if f" {x} " in line]
    assert len(row) == 1 and f" {y} " in row[0] and f" {z} " in row[0] and f"{obj['score']:.3g}" in row[0], res.stdout
