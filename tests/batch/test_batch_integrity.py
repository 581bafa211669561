"""Batch integrity beyond kill-and-resume (issue 23): one row per session in every case.

Symbolic-link loops in globs, unreadable folders, a second run on the same output
folder, part names that never collide, strict ``summary.json``, CSV that reads back
odd folder names, devices as inputs, and outputs that would overwrite an input.
"""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import sys
from pathlib import Path

import pandas as pd
import pytest

from conftest import FAST
from monovisual3d.batch import find_sessions, run, tables
from monovisual3d.errors import InputError

posix_only = pytest.mark.skipif(sys.platform == "win32", reason="symbolic links, devices and flock")


def _reject_constants(name: str) -> None:
    raise ValueError(f"{name} is not JSON")


@posix_only
def test_globs_end_on_symlink_loops_and_count_each_file_once(runs: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    os.symlink(".", runs / "self")
    os.symlink("..", runs / "a" / "up")
    os.symlink(runs / "b", runs / "also_b")  # a second way to the same session
    monkeypatch.chdir(runs.parent)
    ids = [s.session_id for s in find_sessions(["runs/**/session.json"])]
    assert ids == ["a/s0/session.json", "a/s1/session.json", "b/s2/session.json"]
    assert len(find_sessions(["runs/*/*/session.json"])) == 3
    assert len(find_sessions(["runs"])) == 3
    assert len(find_sessions(["runs/**"])) == 3


def test_hidden_names_follow_glob_rules(runs: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    shutil.copytree(runs / "b", runs / ".hidden")
    monkeypatch.chdir(runs.parent)
    assert len(find_sessions(["runs/*/*/session.json"])) == 3  # * does not match a leading dot, as glob.glob
    assert len(find_sessions(["runs/.*/*/session.json"])) == 1


def test_unreadable_folders_are_failed_rows(runs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    locked = runs / "b"
    real_scandir = os.scandir

    def scandir(path: object) -> object:
        if Path(str(path)) == locked:
            raise PermissionError(13, "Permission denied", str(path))
        return real_scandir(path)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "scandir", scandir)
    found = find_sessions([runs])
    assert [s.session_id for s in found] == ["a/s0/session.json", "a/s1/session.json", "b/"]
    assert found[-1].error == f"{locked}: cannot read folder (Permission denied)"
    _, sessions = run([runs], tmp_path / "out", workers=0, **FAST)
    assert list(sessions["status"]) == ["ok", "ok", "error"]
    assert sessions["error"].iloc[-1] == f"{locked}: cannot read folder (Permission denied)"


@posix_only
def test_a_second_run_on_the_same_folder_is_refused(runs: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    with tables.OutputLock(out):  # a first run holds the folder
        with pytest.raises(InputError, match=rf"^{out}: another batch is writing to this folder \(it holds .lock\)"):
            run([runs], out, workers=0, **FAST)
    assert not tables.has_parts(out)
    _, sessions = run([runs], out, workers=0, **FAST)  # released: the folder can be used
    assert len(sessions) == 3


def test_part_names_of_two_runs_never_collide(runs: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    first, second = tables.PartWriter(out), tables.PartWriter(out)  # started at the same moment: same number
    assert first.next_part == second.next_part == 1
    row = {c: None for c in tables.SESSION_COLUMNS}
    first.add({**row, "session_id": "a", "status": "ok"}, [], 0.0)
    second.add({**row, "session_id": "b", "status": "ok"}, [], 0.0)
    first.flush()
    second.flush()
    assert len(list((out / "parts").glob("sessions-000001-*.parquet"))) == 2
    _, sessions = tables.read_parts(out)
    assert sorted(sessions["session_id"]) == ["a", "b"]


def test_summary_is_strict_json(tmp_path: Path) -> None:
    out = tmp_path / "out"
    writer = tables.PartWriter(out)
    row = {c: None for c in tables.SESSION_COLUMNS}
    writer.add({**row, "session_id": "s", "status": "ok", "n_fruit": 0, "n_truth": 2, "n_true_positives": 0}, [], 0.0)
    writer.flush()
    _, _, summary = tables.consolidate(out)
    text = (out / "summary.json").read_text()
    data = json.loads(text, parse_constant=_reject_constants)
    assert data["evaluation"]["precision"] is None and data["evaluation"]["error_mean_m"] is None
    assert data["evaluation"]["recall"] == 0.0


@posix_only
def test_csv_reads_back_odd_folder_names(sim_root: Path, tmp_path: Path) -> None:
    root = tmp_path / "runs"
    names = ["cr\rname", "comma,name", 'quote"name', "new\nline", "plain"]
    for name in names:
        shutil.copytree(sim_root / "a" / "s0", root / name)
    fruit, sessions = run([root], tmp_path / "out", workers=0, **FAST)
    expected = sorted(f"{n}/session.json" for n in names)
    assert list(sessions["session_id"]) == expected
    for name, df in (("sessions", sessions), ("fruit", fruit)):
        raw = (tmp_path / "out" / f"{name}.csv").read_bytes().decode("utf-8")
        rows = list(csv.reader(io.StringIO(raw, newline="")))
        assert len(rows) == len(df) + 1  # one row per session / fruit, plus the header
        back = pd.read_csv(io.StringIO(raw, newline=""), dtype={"session_id": "string"}, keep_default_na=False)
        assert sorted(back["session_id"]) == sorted(df["session_id"])


@posix_only
def test_devices_are_refused_as_batch_inputs(tmp_path: Path) -> None:
    with pytest.raises(
        InputError, match=r"^/dev/zero: is not a regular file \(a device, FIFO or socket\), expected a session file$"
    ):
        run(["/dev/zero"], tmp_path / "out", workers=0, **FAST)


def test_an_output_that_is_an_input_is_refused(runs: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    shutil.copy(runs / "a" / "s0" / "session.json", out / "summary.json")
    before = (out / "summary.json").read_bytes()
    with pytest.raises(InputError, match="is also an output of this batch; refusing to overwrite it"):
        run([out / "summary.json"], out, workers=0, **FAST)
    assert (out / "summary.json").read_bytes() == before


def test_worker_count_is_bounded(runs: Path, tmp_path: Path) -> None:
    from monovisual3d.batch.spread import check_spread
    from monovisual3d.limits import MAX_LOCAL_WORKERS

    n = MAX_LOCAL_WORKERS + 1
    with pytest.raises(InputError, match=rf"^workers: got {n}, more than the {MAX_LOCAL_WORKERS} local processes accepted$"):
        run([runs], tmp_path / "out", workers=n, **FAST)
    with pytest.raises(InputError, match="more than the 256 local processes"):
        check_spread(n, None)
    assert not (tmp_path / "out").exists()  # refused before anything was written
