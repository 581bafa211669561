"""Two processes, as on a robot: ``monovisual3d ros2 play`` -> ``monovisual3d ros2 node`` -> a reader here.

A simulated greenhouse (``monovisual3d simulate --scene greenhouse --noise 0.02``, 5 views) is played at 2 views
per second; the fruit the node publishes are compared with the simulation's truth. Then the node is stopped with
a signal and must exit cleanly (code 0, a ``stopped`` status).
"""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")

from dds_helpers import Collector  # noqa: E402

from monovisual3d.metrics import evaluate  # noqa: E402
from monovisual3d.ros2.config import Topics  # noqa: E402
from monovisual3d.truth import load_objects  # noqa: E402

CLI = [sys.executable, "-m", "monovisual3d.cli"]
#: What the issue asks of 5 views at 2 % box noise.
MIN_RECALL, MAX_MEAN_ERROR_MM = 0.9, 6.0


def _run(args: list[str], timeout: float) -> subprocess.CompletedProcess:
    return subprocess.run(CLI + args, capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("stop_signal", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_play_node_reader(tmp_path: Path, stop_signal: signal.Signals) -> None:
    seed = {signal.SIGINT: 1, signal.SIGTERM: 2}[stop_signal]
    sim = _run(
        [
            "simulate",
            "--scene",
            "greenhouse",
            "--noise",
            "0.02",
            "--views",
            "ring:5",
            "--no-images",
            "--seed",
            str(seed),
            "-o",
            str(tmp_path),
        ],
        300,
    )
    assert sim.returncode == 0, sim.stderr
    topics = Topics()
    out = Collector(topics)
    node = subprocess.Popen(CLI + ["ros2", "node"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert out.wait_for(lambda c: c.last("started") is not None), "the node did not start"
        play = _run(["ros2", "play", str(tmp_path / "session.json"), "--rate", "2"], 300)
        assert play.returncode == 0, play.stdout + play.stderr
        assert "a subscriber on /detections" in play.stdout
        assert out.wait_for(lambda c: (c.last("estimate") or {}).get("views") == 5), f"statuses: {out.statuses[-3:]}"
        estimate = out.detections[-1]
        p_base = np.array(
            [[d.bbox.center.position.x, d.bbox.center.position.y, d.bbox.center.position.z] for d in estimate.detections]
        )
        truth = load_objects(tmp_path / "truth.json")
        m = evaluate(p_base, truth.positions, truth_radii=truth.radii)
        assert m.recall >= MIN_RECALL and m.euclidean_mean * 1e3 <= MAX_MEAN_ERROR_MM, (m.recall, m.euclidean_mean)
        assert estimate.header.frame_id == "base_link"
        assert out.last("estimate")["views_dropped"] == 0
        node.send_signal(stop_signal)
        assert node.wait(30) == 0, node.stdout.read() if node.stdout else ""
        assert out.wait_for(lambda c: c.last("stopped") is not None, 10.0)
    finally:
        if node.poll() is None:
            node.kill()
        out.close()
