"""``batch.run`` on Dask: a local cluster of 2 worker processes (with workers killed in the middle), and a
scheduler plus workers started by hand on localhost, as on a multi-machine cluster."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from pandas.testing import assert_frame_equal

import monovisual3d
from conftest import FAST, comparable
from monovisual3d.batch import run

LOST = "b/s2/session.json"


@pytest.mark.parametrize("chunk_size", [1, 3])
def test_local_cluster_with_killed_workers_loses_and_duplicates_nothing(
    mixed_root: Path, tmp_path: Path, reference, chunk_size: int
) -> None:
    """On 2 worker processes: a/s1 kills its worker once (then succeeds on a retry); b/s2 kills every worker
    that runs it, so it is recorded as failed after ``max_worker_deaths`` (with chunks of 3 sessions per task:
    its chunk is split and the others of the chunk succeed alone); everything else is as in-process."""
    marker = tmp_path / "kill-once"
    marker.write_text("")

    def crashing(session, **kwargs):
        import os

        import monovisual3d as mv3d

        if session.source.endswith(LOST):
            os._exit(1)
        if session.source.endswith("a/s1/session.json") and os.path.exists(marker):
            os.remove(marker)
            os._exit(1)
        return mv3d.localize(session, **kwargs)

    out = tmp_path / "out"
    progress = []
    fruit, sessions = run(
        [mixed_root],
        out,
        workers=2,
        max_worker_deaths=1,
        chunk_size=chunk_size,
        localizer=crashing,
        dashboard_address=None,
        progress=progress.append,
        **FAST,
    )
    assert not marker.exists()  # the first attempt of a/s1 did kill its worker
    assert progress[-1].workers == 2 and progress[-1].done == 6 and progress[-1].failed == 4
    assert sessions["session_id"].is_unique and len(sessions) == 6
    assert not fruit.duplicated(["session_id", "fruit"]).any()
    by_id = sessions.set_index("session_id")
    assert by_id.loc[LOST, "error_type"] == "KilledWorker"
    assert by_id.loc[LOST, "error"].endswith(
        f"{LOST}: the workers running this session died too often (allowed-failures 1): killed or out of memory"
    )
    assert by_id["worker"].drop(index=LOST).str.startswith("tcp://127.0.0.1:").all()
    # everything else is exactly the in-process batch
    expected = comparable(reference.sessions).set_index("session_id").drop(index=LOST)
    assert_frame_equal(comparable(sessions).set_index("session_id").drop(index=LOST), expected)
    keep = reference.fruit["session_id"] != LOST
    assert_frame_equal(fruit, reference.fruit[keep].reset_index(drop=True))
    # a session lost with its workers says nothing about its input: resume runs it again
    fruit2, sessions2 = run([mixed_root], out, workers=0, resume=True, **FAST)
    assert sessions2.set_index("session_id").loc[LOST, "status"] == "ok"
    assert_frame_equal(fruit2, reference.fruit)


def _wait_for(path: Path, proc: subprocess.Popen, seconds: float = 120) -> None:
    t0 = time.monotonic()
    while not path.exists():
        if proc.poll() is not None or time.monotonic() - t0 > seconds:
            raise RuntimeError(f"{proc.args}: did not start (exit code {proc.poll()})")
        time.sleep(0.1)


def test_scheduler_and_workers_started_by_hand(mixed_root: Path, tmp_path: Path, reference) -> None:
    src = str(Path(monovisual3d.__file__).parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (src, os.environ.get("PYTHONPATH")) if p)}
    sched_file = tmp_path / "scheduler.json"
    quiet = {"env": env, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    scheduler = [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard"]
    procs = [subprocess.Popen([*scheduler, "--scheduler-file", str(sched_file)], **quiet)]
    try:
        _wait_for(sched_file, procs[0])
        address = json.loads(sched_file.read_text())["address"]
        worker = [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1", "--no-dashboard", "--no-nanny"]
        procs += [subprocess.Popen(worker, **quiet) for _ in range(2)]
        from distributed import Client

        with Client(address) as client:
            client.wait_for_workers(2, timeout=120)
        progress = []
        fruit, sessions = run([mixed_root], tmp_path / "out", scheduler=address, progress=progress.append, **FAST)
        assert progress[-1].workers == 2
        assert sessions["worker"].str.startswith("tcp://127.0.0.1:").all()
        assert_frame_equal(comparable(sessions), comparable(reference.sessions))
        assert_frame_equal(fruit, reference.fruit)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
