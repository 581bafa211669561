"""The player's messages and time line, without DDS: a node that interpolates TF gets every view's pose exactly."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")

from monovisual3d.camera import Camera  # noqa: E402
from monovisual3d.examples import example_session_path  # noqa: E402
from monovisual3d.io.calibration_ros import camera_from_camera_info  # noqa: E402
from monovisual3d.io.ros_messages import NS_PER_S, detections_from_array, stamp_ns  # noqa: E402
from monovisual3d.ros2.play import PlayConfig, camera_info_msg, detection2d_array_msg, schedule, tf_message  # noqa: E402
from monovisual3d.ros2.tf_buffer import LiveTransforms  # noqa: E402
from monovisual3d.session.load import load_session  # noqa: E402

T0 = 1_800_000_000.0


@pytest.mark.parametrize(
    "camera",
    [
        Camera(640, 480, 500.0, 502.0, 320.5, 240.5),
        Camera(640, 480, 500.0, 502.0, 321.0, 239.0, "plumb_bob", (-0.1, 0.02, 0.001, -0.002, 0.0)),
        Camera(1280, 800, 600.0, 600.0, 640.0, 400.0, "equidistant", (0.1, -0.02, 0.003, -0.001)),
    ],
    ids=["none", "plumb_bob", "equidistant"],
)
def test_camera_info_round_trip(camera: Camera) -> None:
    assert camera_from_camera_info(camera_info_msg(camera, "cam", 0)) == camera


def test_detections_round_trip() -> None:
    boxes = np.array([[10.0, 20.0, 50.0, 80.0], [100.5, 100.25, 120.0, 130.0]])
    msg = detection2d_array_msg(boxes, ["tomato", None], [0.9, None], "cam", 5)
    dets, skipped = detections_from_array(msg)
    assert skipped == []
    assert_allclose([d.bbox_xyxy for d in dets], boxes)
    assert [(d.label, d.score) for d in dets] == [("tomato", 0.9), (None, None)]


def test_tf_between_samples_gives_each_view_pose_and_arrives_late() -> None:
    session = load_session(example_session_path())
    config = PlayConfig(rate_hz=5.0, tf_period_s=0.1, tf_delay_s=0.1)
    events = schedule(session, config, T0)
    buf = LiveTransforms()
    buf.add(tf_message(config.tool_frame, config.camera_frame, config.T_tool_camera, 0), static=True)
    tf_samples = [(when, msg) for when, _, topic, msg in events if topic == config.topics.tf]
    for _, msg in tf_samples:
        buf.add(msg, static=False)
    detections = [(when, msg) for when, _, topic, msg in events if topic == config.topics.detections]
    assert len(detections) == len(session.views)
    for (when, msg), view in zip(detections, session.views, strict=True):
        stamp = stamp_ns(msg.header.stamp) / NS_PER_S
        assert when == pytest.approx(stamp)
        T = buf.lookup(config.base_frame, config.camera_frame, stamp, max_gap=0.1, timeout_s=0.0)
        assert_allclose(T[:3, 3], view.T_base_optical[:3, 3], atol=1e-6)
        assert_allclose(T[:3, :3], view.T_base_optical[:3, :3], atol=1e-6)
        # the samples around the view are 50 ms off its stamp: the nearest alone is millimetres off
        after = min((s for s in tf_samples if stamp_ns(s[1].transforms[0].header.stamp) / NS_PER_S > stamp), key=lambda s: s[0])
        assert after[0] - when == pytest.approx(0.15)  # the sample after the view arrives 150 ms after its detections
        nearest = buf.lookup(config.base_frame, config.camera_frame, stamp + 0.05, max_gap=0.1, timeout_s=0.0)
        assert np.linalg.norm(nearest[:3, 3] - view.T_base_optical[:3, 3]) > 0.004


def test_bad_options() -> None:
    with pytest.raises(Exception, match=r"rate_hz: got 0, expected a positive number"):
        PlayConfig(rate_hz=0)
    with pytest.raises(Exception, match=r"tf_delay_s: got -1, expected a number >= 0"):
        PlayConfig(tf_delay_s=-1)
