"""``bench startup``'s measurements (:mod:`monovisual3d.bench.startup`)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from monovisual3d.bench.startup import COMMANDS, import_seconds, paper_scene_session, run_localize, time_process

IMPORTTIME_LOG = """import time: self [us] | cumulative | imported package
import time:       100 |        100 |   _io
import time:       200 |       1500 | os
import time:       300 |        300 |     posixpath
import time:      1000 |       2500 | numpy
garbage line
"""


def test_import_seconds_sums_the_top_level_imports() -> None:
    assert abs(import_seconds(IMPORTTIME_LOG) - 0.004) < 1e-12


def test_time_process_reports_wall_and_cpu() -> None:
    wall, cpu = time_process([sys.executable, "-c", "sum(range(10**6))"])
    assert wall > 0 and cpu > 0


def test_paper_scene_session_is_the_papers_scene(tmp_path: Path) -> None:
    path = paper_scene_session(tmp_path)
    session = json.loads(Path(path).read_text())
    assert len(session["views"]) == 3
    assert len(json.loads((tmp_path / "truth.json").read_text())["objects"]) == 6
    assert all("{dir}" in " ".join(args) or name == "warmup" for name, args in COMMANDS.items())


def test_run_localize_times_the_whole_process(tmp_path: Path) -> None:
    out = run_localize(str(tmp_path), runs=1, cold_runs=0)
    warm = out["warm cache"]
    assert warm["runs"] == 1 and warm["wall_s"]["median"] > 0 and warm["cpu_s"]["median"] > 0
    assert warm["target_s"] == 0.6 and isinstance(warm["met"], bool)
    assert (tmp_path / "out.json").exists()
