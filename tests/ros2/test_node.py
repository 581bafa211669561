"""The node over DDS in this process, fed by the player: late TF, a burst of views, a reset, a dropped view.

DDS stays on loopback (conftest.py). Each test remaps every topic under its own name.
"""

from __future__ import annotations

import threading
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")

from dds_helpers import Collector, running_node, topics  # noqa: E402

from monovisual3d.api import localize  # noqa: E402
from monovisual3d.examples import example_session_path  # noqa: E402
from monovisual3d.frames import transform_from_position_quaternion  # noqa: E402
from monovisual3d.methods.bayes import BayesConfig  # noqa: E402
from monovisual3d.ros2 import msgs  # noqa: E402
from monovisual3d.ros2.config import NodeConfig  # noqa: E402
from monovisual3d.ros2.play import PlayConfig, play_session  # noqa: E402
from monovisual3d.session.load import load_session  # noqa: E402
from monovisual3d.sim import random_scene, ring_poses, scene_target, simulate  # noqa: E402
from monovisual3d.sim.noise import NoiseModel  # noqa: E402


def _play_in_background(session, config: PlayConfig) -> threading.Thread:  # noqa: ANN001
    thread = threading.Thread(target=play_session, args=(session, config), daemon=True)
    thread.start()
    return thread


def test_late_tf_best_effort_detections_and_a_reset() -> None:
    """TF arrives 150 ms after the detections (samples 100 ms apart, interpolated); detections and camera info come
    best effort (SensorDataQoS); then a reset clears the fruit and a new session starts."""
    session = load_session(example_session_path())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        offline = localize(session).objects[0].position
    t = topics("late_tf")
    out = Collector(t)
    play = PlayConfig(topics=t, rate_hz=5.0, tf_period_s=0.1, tf_delay_s=0.1, sensor_qos=True)
    try:
        with running_node(NodeConfig(topics=t, warmup=False)):
            _play_in_background(session, play).join()
            assert out.wait_for(lambda c: (c.last("estimate") or {}).get("views") == 3)
            s = out.last("estimate")
            assert (s["views_received"], s["views_dropped"], s["fruit"]) == (3, 0, 1)
            d = out.detections[-1].detections
            assert len(d) == 1 and d[0].id == "0"
            p = d[0].bbox.center.position
            assert_allclose([p.x, p.y, p.z], offline, atol=1e-4)  # the poses the node interpolated are the session's

            out.reset_writer.write(msgs.Empty())
            assert out.wait_for(lambda c: c.last("reset") is not None)
            assert out.last("reset")["views"] == 0 and out.last("reset")["fruit"] == 0
            assert out.wait_for(lambda c: c.detections and not c.detections[-1].detections)

            _play_in_background(session, play).join()
            assert out.wait_for(lambda c: (c.statuses[-1].get("views"), c.statuses[-1]["session"]) == (3, 2))
            assert out.detections[-1].detections[0].id == "0"  # track ids start again
    finally:
        out.close()


def test_a_burst_of_50_views_at_5_hz_loses_none() -> None:
    """Views that arrive during an estimate are queued and all used (several per estimate when they come fast)."""
    scene = random_scene(2, rng=3)
    poses = ring_poses(scene_target(scene), 50)
    session, _ = simulate(scene, poses=poses, noise=NoiseModel(box_sigma=0.02), rng=3)
    t = topics("burst")
    out = Collector(t)
    try:
        with running_node(NodeConfig(topics=t, warmup=False), BayesConfig(shape="sphere")):
            _play_in_background(session, PlayConfig(topics=t, rate_hz=5.0)).join()
            assert out.wait_for(lambda c: (c.last("estimate") or {}).get("views") == 50)
        estimates = [s for s in out.statuses if s["event"] == "estimate"]
        assert estimates[-1]["views_received"] == 50 and estimates[-1]["views_dropped"] == 0
        assert sum(s["views_in_estimate"] for s in estimates) == 50
        assert out.last("stopped") is not None or out.wait_for(lambda c: c.last("stopped") is not None, 5.0)
    finally:
        out.close()


def test_a_view_without_its_transform_is_dropped_and_said_so() -> None:
    session = load_session(example_session_path())
    t = topics("dropped")
    out = Collector(t)
    try:
        with running_node(NodeConfig(topics=t, camera_frame="nowhere_optical", tf_timeout_s=0.3, warmup=False)):
            _play_in_background(session, PlayConfig(topics=t, rate_hz=5.0)).join()
            assert out.wait_for(lambda c: (c.last("dropped") or {}).get("views_dropped") == 3)
        reasons = [d["reason"] for d in out.last("dropped")["dropped"]]
        assert len(reasons) == 3 and all("no transform base_link -> nowhere_optical" in r for r in reasons)
        assert out.last("estimate") is None
    finally:
        out.close()


def test_bad_ros_domain_id(monkeypatch: pytest.MonkeyPatch) -> None:
    from monovisual3d.errors import InputError
    from monovisual3d.ros2.node import FruitNode

    monkeypatch.setenv("ROS_DOMAIN_ID", "300")
    with pytest.raises(InputError, match=r"ROS_DOMAIN_ID: got '300', expected an integer from 0 to 232"):
        FruitNode(NodeConfig(warmup=False))


def test_positions_do_not_depend_on_the_reader() -> None:
    """A late-joining subscriber gets the latest estimate at once (transient local, keep last 1)."""
    session = load_session(example_session_path())
    t = topics("late_reader")
    with running_node(NodeConfig(topics=t, warmup=False)):
        first = Collector(t)
        try:
            _play_in_background(session, PlayConfig(topics=t, rate_hz=5.0)).join()
            assert first.wait_for(lambda c: (c.last("estimate") or {}).get("views") == 3)
            late = Collector(t)
            try:
                assert late.wait_for(lambda c: bool(c.detections), 10.0)
                a, b = first.detections[-1].detections[0], late.detections[-1].detections[0]
                assert np.allclose(
                    [a.bbox.center.position.x, a.bbox.center.position.y], [b.bbox.center.position.x, b.bbox.center.position.y]
                )
                assert len(late.detections) == 1
            finally:
                late.close()
        finally:
            first.close()


def test_next_view_as_the_tool_goal_pose() -> None:
    """With candidates and a tool frame, next_view is the tool pose that puts the camera on the chosen candidate
    (composed through the static TF tool -> camera the player publishes); cap candidates look at the fruit."""
    session = load_session(example_session_path())
    t = topics("next_view")
    play = PlayConfig(topics=t, rate_hz=5.0)
    out = Collector(t)
    try:
        with running_node(NodeConfig(topics=t, candidates="cap:12", tool_frame="tool0", warmup=False)):
            _play_in_background(session, play).join()
            assert out.wait_for(lambda c: (c.last("estimate") or {}).get("views") == 3 and bool(c.next_views))
        msg = out.next_views[-1]
        assert msg.header.frame_id == "base_link"
        p, q = msg.pose.position, msg.pose.orientation
        T_base_camera = transform_from_position_quaternion([p.x, p.y, p.z], [q.x, q.y, q.z, q.w]) @ play.T_tool_camera
        fruit = out.detections[-1].detections[0].bbox.center.position
        to_fruit = np.array([fruit.x, fruit.y, fruit.z]) - T_base_camera[:3, 3]
        cos = T_base_camera[:3, 2] @ to_fruit / np.linalg.norm(to_fruit)
        assert np.degrees(np.arccos(min(cos, 1.0))) < 1e-4
        assert "next_view" in out.last("estimate")
    finally:
        out.close()
