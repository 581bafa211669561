"""A/B of localize options: KEY=VALUE parsing, the accuracy and timing runners, and ``bench ab``."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from monovisual3d.bench.accuracy import measure_seed
from monovisual3d.bench.option_ab import (
    DEFAULT,
    accuracy_options,
    format_accuracy,
    format_time,
    option_value,
    parse_options,
    split_options,
    time_options,
    variants,
)
from monovisual3d.cli import app
from monovisual3d.errors import InputError

runner = CliRunner()


def test_values_are_json_where_they_parse() -> None:
    assert option_value("1e9") == 1e9 and option_value("[0.02,0.15]") == [0.02, 0.15]
    assert option_value("true") is True and option_value("null") is None
    assert option_value("auto") == "auto" and option_value("0.01,0.15") == "0.01,0.15"
    assert parse_options(["a=1", "b=x=y"]) == {"a": 1, "b": "x=y"}  # the first = splits


def test_bad_options_are_named() -> None:
    with pytest.raises(InputError, match=r"options: got \['radius_max'\], expected KEY=VALUE"):
        parse_options(["radius_max"])
    with pytest.raises(InputError, match="expected KEY=VALUE"):
        parse_options(["=1"])
    assert variants([]) == {DEFAULT: {}}


def test_split_at_the_double_dash() -> None:
    assert split_options(["cuboid", "--tray", "--", "reach=1.0", "solids=false"]) == (
        ["cuboid", "--tray"],
        {"reach": 1.0, "solids": False},
    )
    assert split_options(["--"]) == ([], {})
    with pytest.raises(InputError, match="expected KEY=VALUE"):
        split_options(["1", "--", "nope"])
    assert variants(["regroup=false", "n_radii=16"]) == {
        DEFAULT: {},
        "regroup=false n_radii=16": {"regroup": False, "n_radii": 16},
    }


def test_accuracy_of_the_default_is_the_benchmarks() -> None:
    """The default variant on ``paper-clean`` scores as ``bench accuracy`` does; a changed option is applied."""
    result = accuracy_options("paper-clean", [0], {DEFAULT: {}, "four views": {"min_views": 4}})
    reference = measure_seed("paper-clean", False, 0, ("bayes",))["bayes"]
    assert_allclose(result[DEFAULT]["mean_mm"], 1e3 * np.mean(reference["errors"]), rtol=1e-12)
    assert result[DEFAULT]["recall"] == 1.0 and result[DEFAULT]["precision"] == 1.0
    assert result["four views"]["recall"] == 0.0  # applied: the scene has three views
    lines = format_accuracy("paper-clean", range(0, 1), result)
    assert lines[0].startswith("paper-clean seeds 0-0, default: mean ") and "recall 1.000" in lines[0]


def test_accuracy_refuses_unknown_conditions_and_no_seeds() -> None:
    with pytest.raises(InputError, match="condition: got 'nope', expected one of"):
        accuracy_options("nope", [0], {DEFAULT: {}})
    with pytest.raises(InputError, match="seeds: none given"):
        accuracy_options("paper-clean", [], {DEFAULT: {}})


def test_time_options_times_every_variant_on_every_scene() -> None:
    result = time_options({DEFAULT: {}, "n_radii=8": {"n_radii": 8}}, rounds=1, mixed_seeds=(0,))
    assert set(result) == {DEFAULT, "n_radii=8"}
    for scenes in result.values():
        assert set(scenes) == {"paper scene", "mixed shapes"} and all(t > 0 for t in scenes.values())
    assert format_time(result)[0].startswith("default: paper scene ")
    with pytest.raises(InputError, match="rounds: got 0"):
        time_options({DEFAULT: {}}, rounds=0)


def test_cli_bench_ab_accuracy() -> None:
    out = runner.invoke(app, ["bench", "ab", "accuracy", "paper-clean", "0", "1", "min_views=4"])
    assert out.exit_code == 0, out.output
    lines = [line for line in out.stdout.splitlines() if line.startswith("paper-clean seeds 0-0")]
    assert len(lines) == 2
    assert ", default: mean" in lines[0] and "recall 1.000" in lines[0]
    assert ", min_views=4: mean nan" in lines[1] and "recall 0.000" in lines[1]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["accuracy", "paper-clean", "0", "1", "radius_max"], "expected KEY=VALUE"),
        (["accuracy", "paper-clean", "3", "1", "regroup=false"], "LAST: got 1, expected more than FIRST"),
        (["accuracy", "nope", "0", "1", "regroup=false"], "condition: got 'nope'"),
        (["time", "--rounds", "0", "regroup=false"], "--rounds"),
    ],
)
def test_cli_bench_ab_bad_input(args: list[str], message: str) -> None:
    out = runner.invoke(app, ["bench", "ab", *args])
    assert out.exit_code == 2
    assert message in out.output
