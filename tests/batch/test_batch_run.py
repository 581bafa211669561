"""``batch.run`` in-process (``workers=0``): tables, bad sessions, truth, parts, resume, argument errors."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from pandas.testing import assert_frame_equal

import monovisual3d as mv3d
from conftest import FAST, comparable
from monovisual3d.batch import FRUIT_COLUMNS, SESSION_COLUMNS, BatchProgress, read_tables, run
from monovisual3d.batch.run import check_not_spawned_import
from monovisual3d.errors import InputError


def test_tables_match_localize_and_truth(runs: Path, tmp_path: Path) -> None:
    fruit, sessions = run([runs], tmp_path / "out", workers=0, **FAST)
    assert list(sessions["status"]) == ["ok"] * 3
    assert list(sessions["session_id"]) == ["a/s0/session.json", "a/s1/session.json", "b/s2/session.json"]
    for sid, path in zip(sessions["session_id"], sessions["path"]):
        expected = mv3d.localize(path, **FAST)
        rows = fruit[fruit["session_id"] == sid]
        assert list(rows["fruit"]) == list(range(len(expected.objects)))
        assert_allclose(rows[["x_m", "y_m", "z_m"]].to_numpy(), expected.positions, atol=1e-12)
        assert_allclose(rows["score"], [o.score for o in expected.objects])
        cov = np.stack([o.covariance for o in expected.objects])
        assert_allclose(rows["cov_xy_m2"], cov[:, 0, 1])
        assert_allclose(rows["cov_zz_m2"], cov[:, 2, 2])
    row = sessions.iloc[0]
    assert (row["n_views"], row["n_detections"], row["method"]) == (3, 18, "paper")
    assert json.loads(row["options"]) == {"resolution": 0.05}
    assert len(row["input_sha256"]) == 64
    # truth.json beside each session: the evaluation of `monovisual3d evaluate`, and each fruit's matched truth
    for _, row in sessions.iterrows():
        truth = json.loads((Path(row["path"]).parent / "truth.json").read_text())["objects"]
        t_pos = np.array([t["position"] for t in truth])
        rows = fruit[fruit["session_id"] == row["session_id"]]
        est = rows[["x_m", "y_m", "z_m"]].to_numpy()
        m = mv3d.evaluate(est, t_pos, truth_radii=[t["radius"] for t in truth])
        assert (row["n_truth"], row["n_true_positives"]) == (6, m.true_positives)
        assert_allclose([row["recall"], row["precision"], row["error_mean_m"]], [m.recall, m.precision, m.euclidean_mean])
        assert rows["truth_id"].notna().all() and rows["truth_id"].is_unique
        assert_allclose(rows["error_m"], np.linalg.norm(est - t_pos[rows["truth_id"].to_numpy(int)], axis=1))
        assert_allclose(rows["error_m"].mean(), m.euclidean_mean)


def test_bad_sessions_are_recorded_and_the_batch_goes_on(mixed: Path, tmp_path: Path) -> None:
    fruit, sessions = run([mixed], tmp_path / "out", workers=0, **FAST)
    by_id = sessions.set_index("session_id")
    assert set(fruit["session_id"]) == {"a/s0/session.json", "a/s1/session.json", "b/s2/session.json"}
    bad = by_id.loc[["bad/corrupt/session.json", "bad/empty/session.json", "bad/invalid/session.json"]]
    assert (bad["status"] == "error").all() and (bad["error_type"] == "InputError").all()
    assert (
        bad["error"]
        .iloc[0]
        .endswith("corrupt/session.json: not valid JSON at line 1, column 26: Expecting property name enclosed in double quotes")
    )
    assert "empty/session.json: not valid JSON at line 1, column 1" in bad["error"].iloc[1]
    assert "invalid/session.json: camera: missing field" in bad["error"].iloc[2]
    assert (by_id["status"] == "ok").sum() == 3
    assert by_id.loc["bad/corrupt/session.json", "n_views"] is pd.NA


def test_an_option_error_stops_the_batch_before_any_session(runs: Path, tmp_path: Path) -> None:
    for options, match in (({"colour": "red"}, "colour: not an option of method 'paper'"), ({"resolution": -1}, "resolution")):
        with pytest.raises(InputError, match=match):
            run([runs], tmp_path / "out", workers=0, method="paper", **options)
        assert not (tmp_path / "out" / "parts").exists()


def test_outputs_are_readable_with_the_documented_types(mixed: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    fruit, sessions = run([mixed], out, workers=0, **FAST)
    f2, s2 = read_tables(out)
    assert dict(f2.dtypes.astype(str)) == FRUIT_COLUMNS and dict(s2.dtypes.astype(str)) == SESSION_COLUMNS
    assert_frame_equal(f2, fruit)
    assert_frame_equal(s2, sessions)
    raw = pd.read_parquet(out / "sessions.parquet")
    assert dict(raw.dtypes.astype(str)) == SESSION_COLUMNS  # pandas metadata keeps the dtypes
    csv = pd.read_csv(out / "fruit.csv")
    assert list(csv.columns) == list(FRUIT_COLUMNS)
    assert_allclose(csv["x_m"], fruit["x_m"])
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["n_sessions"], summary["n_ok"], summary["n_error"], summary["n_fruit"]) == (6, 3, 3, len(fruit))
    assert summary["evaluation"]["n_truth"] == 18


def test_parts_are_written_as_results_arrive(runs: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    seen = []

    def progress(p: BatchProgress) -> None:
        seen.append((p.done, p.total, p.failed, len(list((out / "parts").glob("sessions-*.parquet")))))

    run([runs], out, workers=0, part_size=1, progress=progress, **FAST)
    # a first call before any session, then the part of each session is on disk before the next one starts
    assert seen == [(0, 3, 0, 0), (1, 3, 0, 1), (2, 3, 0, 2), (3, 3, 0, 3)]


class Stop(Exception):
    pass


def test_resume_after_an_interruption_gives_the_uninterrupted_tables(mixed: Path, tmp_path: Path) -> None:
    full_f, full_s = run([mixed], tmp_path / "full", workers=0, **FAST)

    def stop_after_two(p: BatchProgress) -> None:
        if p.done == 2:
            raise Stop

    out = tmp_path / "out"
    with pytest.raises(Stop):
        run([mixed], out, workers=0, part_size=1, progress=stop_after_two, **FAST)
    with pytest.raises(InputError, match="holds an earlier batch; resume it"):
        run([mixed], out, workers=0, **FAST)
    calls = []

    def counting(session, **kwargs):
        calls.append(session.source)
        return mv3d.localize(session, **kwargs)

    progress: list[BatchProgress] = []
    fruit, sessions = run([mixed], out, workers=0, resume=True, localizer=counting, progress=progress.append, **FAST)
    assert progress[-1].skipped == 2 and progress[-1].done == 4  # a/s0, a/s1 done before the stop
    assert [Path(c).parent.name for c in calls] == ["s2"]  # the 3 bad sessions fail before localisation
    assert_frame_equal(comparable(sessions), comparable(full_s))
    assert_frame_equal(fruit, full_f)


def test_resume_reruns_sessions_whose_content_or_options_changed(runs: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    run([runs], out, workers=0, **FAST)
    data = json.loads((runs / "b/s2/session.json").read_text())
    data["views"] = data["views"][:2]
    (runs / "b/s2/session.json").write_text(json.dumps(data))
    seen: list[BatchProgress] = []
    fruit, sessions = run([runs], out, workers=0, resume=True, progress=seen.append, **FAST)
    assert [p.last["session_id"] for p in seen if p.last] == ["b/s2/session.json"]
    assert (seen[0].total, seen[0].skipped) == (1, 2)  # known from the start
    assert list(sessions.set_index("session_id")["n_views"]) == [3, 3, 2]
    seen.clear()
    _, s2 = run([runs], out, workers=0, resume=True, progress=seen.append, method="paper", resolution=0.06)
    assert sum(p.last is not None for p in seen) == 3 and len(s2) == 3
    assert (s2["options"] == '{"resolution": 0.06}').all()
    assert not fruit.duplicated(["session_id", "fruit"]).any()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"workers": -1}, "workers: got -1, expected 0"),
        ({"workers": 2, "scheduler": "tcp://x:1"}, "workers, scheduler: give at most one"),
        ({"workers": 0, "part_size": 0}, "part_size: got 0"),
        ({"workers": 0, "max_worker_deaths": 0}, "max_worker_deaths: got 0"),
        ({"workers": 0, "chunk_size": 0}, "chunk_size: got 0"),
        ({"workers": 0, "method": "magic"}, "method: got 'magic', expected one of"),
    ],
)
def test_bad_arguments_are_one_line_errors(runs: Path, tmp_path: Path, kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        run([runs], tmp_path / "out", **kwargs)


def test_output_must_be_a_folder(runs: Path, tmp_path: Path) -> None:
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match="file: exists and is not a folder"):
        run([runs], tmp_path / "file", workers=0, **FAST)


def test_local_workers_asked_for_while_a_spawned_worker_imports_the_script(
    runs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A script calling ``run`` at its top level: each spawned worker runs it again as ``__mp_main__`` (a module other
    than the worker's ``__main__``) and would start workers of its own; it stops there with the guard to add, before
    touching the output folder, while a worker-less run and one on a given scheduler are not concerned."""
    monkeypatch.setitem(sys.modules, "__mp_main__", types.ModuleType("__mp_main__"))
    run_module = sys.modules[check_not_spawned_import.__module__]  # (the package exports the function ``run`` by that name)
    monkeypatch.setattr(run_module, "_in_main_process", lambda: False)  # a spawned worker
    with pytest.raises(InputError, match=r'workers: .* under `if __name__ == "__main__":`'):
        run([runs], tmp_path / "out", workers=2, **FAST)
    assert not (tmp_path / "out").exists()
    fruit, sessions = run([runs], tmp_path / "in_process", workers=0, **FAST)
    assert set(sessions["status"]) == {"ok"}
    monkeypatch.setattr(run_module, "_in_main_process", lambda: True)  # a notebook's main process: its own __main__
    check_not_spawned_import()
