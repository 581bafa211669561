"""``monovisual3d batch``: options, outputs, exit codes."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from monovisual3d.cli import app
from monovisual3d.cli.options import parse_options
from monovisual3d.errors import InputError

FAST = ["--workers", "0", "--method", "paper", "--option", "resolution=0.05"]


def test_parse_options_reads_json_values_and_keeps_text() -> None:
    assert parse_options(["resolution=0.01", "k=3", "kernel=gaussian", "weighted_kmeans=false", "centre=[1, 2]"]) == {
        "resolution": 0.01,
        "k": 3,
        "kernel": "gaussian",
        "weighted_kmeans": False,
        "centre": [1, 2],
    }
    assert parse_options(None) == {}


@pytest.mark.parametrize("item", ["resolution", "=3", "two words=1"])
def test_parse_options_rejects_what_is_not_key_value(item: str) -> None:
    with pytest.raises(InputError, match="--option: got .*, expected KEY=VALUE"):
        parse_options([item])


def test_batch_writes_tables_and_exits_1_when_a_session_failed(mixed_root: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["batch", str(mixed_root), "--output", str(out), *FAST, "--quiet"])
    assert result.exit_code == 1, result.output
    assert "3 ok, 3 failed, " in result.output
    assert "failed: bad/corrupt/session.json: " in result.output
    assert "against truth.json (3 sessions): recall" in result.output
    for name in ("fruit.parquet", "fruit.csv", "sessions.parquet", "sessions.csv", "summary.json"):
        assert (out / name).is_file()
    assert list(pd.read_csv(out / "sessions.csv")["status"]) == ["ok"] * 3 + ["error"] * 3


def test_batch_exits_0_with_progress_when_all_sessions_pass_and_resumes(sim_root: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["batch", str(sim_root), "-o", str(out), *FAST])
    assert result.exit_code == 0, result.output
    assert "running 3 session(s) in this process" in result.output and "3 ok, 0 failed" in result.output
    again = CliRunner().invoke(app, ["batch", str(sim_root), "-o", str(out), *FAST])
    assert again.exit_code == 2 and "holds an earlier batch; resume it" in again.output
    resumed = CliRunner().invoke(app, ["batch", str(sim_root), "-o", str(out), *FAST, "--resume", "--quiet"])
    assert resumed.exit_code == 0 and "3 ok, 0 failed" in resumed.output


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--workers", "1", "--scheduler", "tcp://127.0.0.1:1"], "--workers, --scheduler: give one of them"),
        (["--option", "oops"], "--option: got 'oops', expected KEY=VALUE"),
        (["--workers", "0", "--method", "magic"], "method: got 'magic'"),
    ],
)
def test_batch_usage_errors_exit_2(sim_root: Path, tmp_path: Path, args: list[str], message: str) -> None:
    result = CliRunner().invoke(app, ["batch", str(sim_root), "-o", str(tmp_path / "out"), *args])
    assert result.exit_code == 2
    assert message in result.output


def test_batch_missing_input_exits_2(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["batch", str(tmp_path / "nope"), "-o", str(tmp_path / "out"), "--workers", "0"])
    assert result.exit_code == 2 and "nope: no such file or folder" in result.output
