"""Against Cyclone DDS 0.10 in C, the version ROS 2 Humble and Jazzy ship: a peer with no XTypes type information.

``rmw_cyclonedds_cpp`` endpoints carry no type information, so Cyclone matches them with the node's by topic and
type name; this peer is built the same way (``idlc -t``) from IDL written by hand in ``c_peer/ros_msgs.idl``,
with rmw_cyclonedds_cpp's QoS. It checks each message the test hands it with Cyclone's own stream code, reads it
into the C type and writes it with ``dds_write`` (so the node receives Cyclone 0.10's serialisation), and prints
every Detection3DArray it takes with ``dds_take`` (so the node's bytes are read by Cyclone 0.10's deserialiser).

Needs ``idlc``, a C compiler and the Cyclone DDS C headers and library (Debian: ``apt-get install cyclonedds-dev
cyclonedds-tools``); skipped otherwise.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import threading
import time
from pathlib import Path

import pytest
from numpy.testing import assert_allclose

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")

from dds_helpers import ANSWER_S, running_node, topics  # noqa: E402

from monovisual3d.api import localize  # noqa: E402
from monovisual3d.examples import example_session_path  # noqa: E402
from monovisual3d.io.ros_messages import NS_PER_S  # noqa: E402
from monovisual3d.ros2.config import NodeConfig  # noqa: E402
from monovisual3d.ros2.play import PlayConfig, schedule, tf_message  # noqa: E402
from monovisual3d.session.load import load_session  # noqa: E402

SOURCES = Path(__file__).parent / "c_peer"


@pytest.fixture(scope="module")
def peer(tmp_path_factory: pytest.TempPathFactory) -> Path:
    idlc, cc = shutil.which("idlc"), shutil.which("cc") or shutil.which("gcc")
    if idlc is None or cc is None:
        pytest.skip("needs idlc and a C compiler (Debian: apt-get install cyclonedds-dev cyclonedds-tools gcc)")
    out = tmp_path_factory.mktemp("c_peer")
    subprocess.run([idlc, "-t", "-o", str(out), str(SOURCES / "ros_msgs.idl")], check=True, capture_output=True)
    build = subprocess.run(
        [cc, "-O1", "-o", str(out / "peer"), str(SOURCES / "peer.c"), str(out / "ros_msgs.c"), f"-I{out}", "-lddsc"],
        capture_output=True,
        text=True,
    )
    if build.returncode != 0:
        pytest.skip(f"cannot build the C peer (Cyclone DDS C headers and library missing?): {build.stderr.strip()[:300]}")
    return out / "peer"


def test_a_cyclone_010_peer_without_type_information(peer: Path) -> None:
    session = load_session(example_session_path())
    t = topics("c_peer")
    proc = subprocess.Popen(
        [str(peer), os.environ["ROS_DOMAIN_ID"], "/c_peer"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
    )
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(line.rstrip() for line in proc.stdout), daemon=True).start()  # type: ignore[union-attr]
    assert proc.stdin is not None
    try:
        with running_node(NodeConfig(topics=t, warmup=False)):
            deadline = time.monotonic() + 20
            while "matched" not in lines and time.monotonic() < deadline:
                time.sleep(0.05)
            assert "matched" in lines, f"the C peer's writer never matched the node's reader: {lines}"
            play = PlayConfig(topics=t, rate_hz=5.0, tf_period_s=0.1, tf_delay_s=0.1)
            kinds = {t.camera_info: "camera_info", t.detections: "detections", t.tf: "tf"}
            static = tf_message(play.tool_frame, play.camera_frame, play.T_tool_camera, int(time.time() * NS_PER_S))
            proc.stdin.write(f"pub tf_static {static.serialize().hex()}\n")
            for when, _, topic, msg in schedule(session, play, time.time() + 0.3):
                time.sleep(max(when - time.time(), 0.0))
                proc.stdin.write(f"pub {kinds[topic]} {msg.serialize().hex()}\n")
            deadline = time.monotonic() + ANSWER_S
            while time.monotonic() < deadline and not any(line.startswith("det3d 1 ") for line in lines[-3:]):
                time.sleep(0.1)
        proc.stdin.write("quit\n")
        proc.stdin.flush()
        assert proc.wait(20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
    fruit = [line.split() for line in lines if line.startswith("fruit ")]
    assert fruit, f"the C peer took no Detection3DArray: {lines[-5:]}"
    _, track, x, y, z, sx, sy, sz, cov_xx, label, score = fruit[-1]
    assert track == "0" and label == "tomato"
    assert_allclose([float(x), float(y), float(z)], localize(session).objects[0].position, atol=1e-4)
    assert float(sx) == float(sy) == float(sz) > 0 and float(cov_xx) > 0
    assert float(score) == pytest.approx(sum(v.detections[0].score for v in session.views) / len(session.views))
