"""``bench scale`` (issue 22): row sweeps over fruit and views, growth factor, JSON."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from monovisual3d.bench.scale import format_table, growth, run_scale
from monovisual3d.cli import app

runner = CliRunner()


def test_run_scale_small(tmp_path):
    result = run_scale(fruit=(3, 6), views=(2,), seeds=(0,), repeats=1, busy=False)
    rows = result["rows"]
    assert [(r["sweep"], r["fruit"], r["views"]) for r in rows] == [("fruit", 3, 5), ("fruit", 6, 5), ("views", 48, 2)]
    for r in rows:
        assert r["time_s"] > 0 and 0 <= r["recall"] <= 1 and r["boxes_per_view"] > 0
    assert rows[1]["recall"] == 1.0 and rows[1]["mean_mm"] < 10
    g = result["growth"]["idle"]
    assert (g["from"], g["to"]) == (3, 6) and g["ratio"] == rows[1]["time_s"] / rows[0]["time_s"]
    assert len(format_table(result)) == 3 and all(r["cpu_s"] > 0 for r in rows) and result["meta"]["cores"] >= 1


def test_growth_uses_the_largest_count_up_to_96():
    rows = [{"sweep": "fruit", "load": "idle", "fruit": n, "time_s": t} for n, t in ((12, 1.0), (96, 6.0), (192, 20.0))]
    assert growth(rows) == {"idle": {"ratio": 6.0, "from": 12, "to": 96}}


def test_bench_scale_cli(tmp_path):
    out = tmp_path / "scale.json"
    args = ["bench", "scale", "--fruit", "4", "--views", "2", "--seeds", "1", "--idle-only", "-o", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    data = json.loads(out.read_text())
    assert data["meta"]["seeds"] == [1] and len(data["rows"]) == 2
    bad = runner.invoke(app, ["bench", "scale", "--fruit", "a,b"])
    assert bad.exit_code == 2 and "--fruit: got 'a,b'" in bad.output
