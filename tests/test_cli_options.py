"""The method options on the command line (``cli/options.py``, ``cli/panels.py``, ``cli/reference.py``): the short
``localize --help`` in panels, ``--help-all``, ``monovisual3d options``, ``--set NAME=VALUE`` and the hidden expert flags."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from cli_checks import assert_one_line_error
from monovisual3d.cli import app
from monovisual3d.cli.options import (
    DEVELOPER_GROUPS,
    USER_OPTIONS,
    MethodOptions,
    method_config,
    method_fields,
    option_specs,
)
from monovisual3d.examples import example_session_path
from monovisual3d.methods import METHODS
from monovisual3d.methods.bayes.config import BayesConfig, BayesTuning
from monovisual3d.methods.bayes.sensor import SensorModel

#: The issue's bounds on ``localize --help`` (measured at 100 columns).
MAX_HELP_LINES = 90
MAX_HELP_OPTIONS = 25
#: Wide enough that no flag or help text is cut in the tests that look for them.
WIDE = {"COLUMNS": "250"}
#: A flag at the start of a help panel's row: ``│ --accept ...`` or ``│ -o, ...``.
ROW_FLAG = re.compile(r"^│\s+(?:\*\s+)?(--?[a-z][a-z0-9-]*)", flags=re.M)


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def _help(runner: CliRunner, *args: str, env: dict[str, str] = WIDE) -> str:
    res = runner.invoke(app, ["localize", *args], env=env)
    assert res.exit_code == 0, res.output
    return res.stdout


def test_localize_help_is_short_and_in_panels(runner: CliRunner) -> None:
    out = _help(runner, "--help", env={"COLUMNS": "100"})
    flags = ROW_FLAG.findall(out)
    assert len(out.splitlines()) <= MAX_HELP_LINES, len(out.splitlines())
    assert len(flags) <= MAX_HELP_OPTIONS, flags
    panels = re.findall(r"^╭─ (.+?) ─", out, flags=re.M)
    assert panels == ["Arguments", "What to find", "Scene and poses", "Output", "Limits", "More options"], panels
    user = {"--" + n.replace("_", "-") for n in USER_OPTIONS}
    own = {"--method", "--output", "--quiet", "--view", "--strict", "--time-limit", "--set", "--help-all", "--help"}
    assert set(flags) == user | own, set(flags) ^ (user | own)


def test_the_user_options_are_options_of_a_method() -> None:
    """Every name of the decision table is a method option (no stale entry), and the developer groups exist."""
    specs = {s.name: s for s in option_specs()}
    assert set(USER_OPTIONS) <= set(specs)
    assert {s.name for s in specs.values() if s.audience == "user"} == set(USER_OPTIONS)
    assert {f.group for m in METHODS.values() for f in method_fields(m)} >= set(DEVELOPER_GROUPS)


def test_help_all_lists_every_option_of_every_method(runner: CliRunner) -> None:
    out = _help(runner, "--help-all")
    flags = set(ROW_FLAG.findall(out))
    for method in METHODS.values():
        for f in method_fields(method):
            if f.audience == "developer":
                assert f"--set {f.name}=" in out, f.name
            else:
                assert "--" + f.name.replace("_", "-") in flags, (method.name, f.name)
    panels = re.findall(r"^╭─ (.+?) ─", out, flags=re.M)
    for title in ("Expert: bayes method", "Expert: bayes sensor model", "Expert: paper method", "Expert: quadric method"):
        assert title in panels, panels
    assert "Developer knobs: bayes tuning (--set NAME=VALUE)" in panels


def test_the_expert_flags_are_hidden_from_help(runner: CliRunner) -> None:
    short = set(ROW_FLAG.findall(_help(runner, "--help")))
    assert not {"--alpha", "--kernel", "--resolution", "--backend", "--min-views"} & short
    assert not {"--swap", "--lookahead"} & set(ROW_FLAG.findall(_help(runner, "--help-all")))  # developer: --set only


def test_options_shows_the_sensor_and_tuning_sections(runner: CliRunner) -> None:
    res = runner.invoke(app, ["options", "bayes"])
    assert res.exit_code == 0, res.output
    out = res.stdout
    assert "bayes method" in out and "bayes sensor model (sensor)" in out
    assert "bayes developer knobs (tuning): --set NAME=VALUE, no flags" in out
    rows = {cells[0]: cells[1:] for cells in _table_rows(out)}
    for cls in (BayesConfig, SensorModel, BayesTuning):
        for f in dataclasses.fields(cls):
            if f.name not in ("sensor", "tuning"):
                assert f.name in rows, f.name
    assert rows["alpha"][:3] == ["--alpha", "0.05", "expert"]
    assert rows["swap"][:3] == ["--set swap=true|false", "on", "developer"]
    assert rows["accept"][:3] == ["--accept", "8", "user"]
    assert "the swap pass" in rows["swap"][3]


def _table_rows(text: str) -> list[list[str]]:
    """The cells of the rows of rich tables (``│ a │ b │``), first lines only."""
    return [[c.strip() for c in line.strip("│ ").split("│")] for line in text.splitlines() if line.startswith("│")]


def test_options_of_every_method_and_a_bad_name(runner: CliRunner) -> None:
    res = runner.invoke(app, ["options"])
    assert res.exit_code == 0, res.output
    assert all(f"{m} method" in res.stdout for m in METHODS)
    rows = {cells[0]: cells[1:] for cells in _table_rows(res.stdout)}
    assert rows["kernel"][:3] == ["--kernel", "gaussian", "expert"]
    assert_one_line_error(runner.invoke(app, ["options", "bayse"]), "METHOD: got 'bayse', expected one of")


def test_set_reaches_a_tuning_field_and_a_hidden_flag_still_works(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "result.json"
    args = ["localize", str(example_session_path()), "-q", "-o", str(out), "--resolution", "0.02", "--alpha", "0.06"]
    res = runner.invoke(app, [*args, "--set", "swap=false", "--set", "lookahead=1", "--set", "elongations=1"])
    assert res.exit_code == 0, res.output
    config = json.loads(out.read_text())["config"]
    assert config["resolution"] == 0.02 and config["sensor"]["alpha"] == 0.06
    assert config["tuning"]["swap"] is False and config["tuning"]["lookahead"] == 1 and config["tuning"]["elongations"] == [1.0]


def test_method_config_from_set_and_flags() -> None:
    cfg = method_config("bayes", MethodOptions.given({"accept": 12.0}, ["second_look=false", "p_miss=0.2"]))
    assert cfg.accept == 12.0 and cfg.tuning.second_look is False and cfg.sensor.p_miss == 0.2
    assert method_config("paper", {"k": "3"}).k == 3  # a plain mapping: flags by name


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (["--set", "swapp=1"], ["--set swapp: not an option of --method bayes", "did you mean swap?"]),
        (["--set", "swap=maybe"], ["--set swap: got 'maybe', expected true or false"]),
        (["--set", "lookahead=0"], ["--set lookahead: got 0, expected an integer >= 1"]),
        (["--set", "kernel=square"], ["--set kernel: not an option of --method bayes (it applies to --method paper)"]),
        (["--set", "swap"], ["--set: got 'swap', expected KEY=VALUE"]),
        (["--accept", "10", "--set", "accept=12"], ["--accept, --set accept: give one of them"]),
        (["--alpha", "-1"], ["--alpha: alpha must be >= 0"]),
        (["--method", "paper", "--set", "k=0"], ["--set k: got 0"]),
    ],
)
def test_set_and_expert_flags_are_refused_as_typed(runner: CliRunner, args: list[str], fragments: list[str]) -> None:
    assert_one_line_error(runner.invoke(app, ["localize", str(example_session_path()), "-q", *args]), *fragments)
