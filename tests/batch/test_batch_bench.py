"""``bench batch``: it runs end to end on a tiny batch and rejects bad worker counts."""

from __future__ import annotations

import statistics
from pathlib import Path

import pytest
from typer.testing import CliRunner

from monovisual3d.bench.batch import format_rows, run_bench_batch
from monovisual3d.cli import app


def test_bench_batch_times_the_loop_and_one_worker(tmp_path: Path) -> None:
    result = run_bench_batch(
        n_sessions=2, worker_counts=(1,), method="paper", options={"resolution": 0.05}, data=tmp_path / "s", repeats=2
    )
    assert sorted(p.name for p in (tmp_path / "s").iterdir()) == ["s00000", "s00001"]
    assert result["meta"]["n_sessions"] == 2 and [r["workers"] for r in result["batch"]] == [1]
    row = result["batch"][0]
    assert len(row["wall_s"]) == len(result["loop"]["wall_s"]) == 2
    assert row["sessions_per_s"] == pytest.approx(2 / statistics.median(row["wall_s"]))
    paired = [1000 * (b - a) / 2 for a, b in zip(result["loop"]["wall_s"], row["wall_s"])]  # ms per session, each repeat
    assert result["derived"]["overhead_per_session_ms_runs"] == pytest.approx(paired)
    assert result["derived"]["overhead_per_session_ms"] == pytest.approx(statistics.median(paired))
    assert "speedup_2w_over_1w" not in result["derived"]
    assert any(line.startswith("batch, 1 worker(s): ") for line in format_rows(result))


@pytest.mark.parametrize(("workers", "message"), [("one", "expected integers"), ("0,2", "expected positive worker counts")])
def test_bench_batch_rejects_bad_worker_counts(workers: str, message: str) -> None:
    result = CliRunner().invoke(app, ["bench", "batch", "--workers", workers])
    assert result.exit_code == 2 and message in result.output
