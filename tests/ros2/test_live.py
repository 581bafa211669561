"""One live session without DDS: views resolved against live TF (late TF waited for), estimates, reset, drops."""

from __future__ import annotations

import threading
import time
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")

from monovisual3d.examples import example_session_path  # noqa: E402
from monovisual3d.frames import T_cameralink_optical, invert_transform  # noqa: E402
from monovisual3d.io.ros_messages import NS_PER_S  # noqa: E402
from monovisual3d.methods.bayes import BayesConfig, BayesLocalizer  # noqa: E402
from monovisual3d.ros2.config import NodeConfig  # noqa: E402
from monovisual3d.ros2.live import LatestCamera, LiveSession, PendingView, ViewDropped, resolve_view  # noqa: E402
from monovisual3d.ros2.play import tf_message  # noqa: E402
from monovisual3d.ros2.tf_buffer import LiveTransforms  # noqa: E402
from monovisual3d.session.load import load_session  # noqa: E402

T0 = 1_800_000_000.0
SESSION = load_session(example_session_path())


def _pending(i: int, frame: str = "cam", arrived: float | None = None) -> PendingView:
    view = SESSION.views[i]
    return PendingView(int(round((T0 + i) * NS_PER_S)), frame, view.detections, time.monotonic() if arrived is None else arrived)


def _tf_around(buf: LiveTransforms, i: int, T_base_cam: np.ndarray, offset: np.ndarray) -> None:
    """Samples 100 ms apart around view i's stamp (T0 + i), moving linearly through ``T_base_cam``."""
    for dt, sign in ((-0.05, -1.0), (0.05, 1.0)):
        T = T_base_cam.copy()
        T[:3, 3] += sign * offset
        buf.add(tf_message("base", "cam", T, int(round((T0 + i + dt) * NS_PER_S))), static=False)


def _config(**kw) -> NodeConfig:
    return NodeConfig(base_frame="base", warmup=False, **kw)


def test_a_view_waits_for_tf_150_ms_late_and_gets_the_interpolated_pose() -> None:
    buf, cams = LiveTransforms(), LatestCamera()
    cams.set(SESSION.camera)
    T = SESSION.views[0].T_base_optical
    offset = np.array([0.004, -0.003, 0.002])
    threading.Timer(0.15, _tf_around, (buf, 0, T, offset)).start()
    view, camera = resolve_view(_pending(0), buf, cams, _config())
    assert camera == SESSION.camera
    assert_allclose(view.T_base_optical, T, atol=1e-6)
    assert view.detections == SESSION.views[0].detections and view.stamp == pytest.approx(T0)


def test_camera_link_frames_are_turned_to_optical() -> None:
    buf, cams = LiveTransforms(), LatestCamera()
    cams.set(SESSION.camera)
    T_optical = SESSION.views[0].T_base_optical
    _tf_around(buf, 0, T_optical @ invert_transform(T_cameralink_optical()), np.zeros(3))
    view, _ = resolve_view(_pending(0), buf, cams, _config(pose_frame="camera_link"))
    assert_allclose(view.T_base_optical, T_optical, atol=1e-6)


def test_a_view_without_its_pose_is_dropped_with_the_reason() -> None:
    buf, cams = LiveTransforms(), LatestCamera()
    cams.set(SESSION.camera)
    with pytest.raises(
        ViewDropped,
        match=r"no transform base -> cam at .* within 0.1 s: base frame 'base' is not in the transforms; frames seen: \[\]",
    ):
        resolve_view(_pending(0), buf, cams, _config(tf_timeout_s=0.1))
    with pytest.raises(ViewDropped, match=r"no header.frame_id: give the camera frame \(--camera-frame\)"):
        resolve_view(_pending(0, frame=""), buf, cams, _config())
    with pytest.raises(ViewDropped, match=r"no CameraInfo on /camera/camera_info within 0 s"):
        resolve_view(_pending(0), buf, LatestCamera(), _config(tf_timeout_s=0.0))


def _fed_session(**kw) -> LiveSession:
    live = LiveSession(_config(**kw), BayesConfig())
    for i, view in enumerate(SESSION.views):
        assert live.add(view.__class__(view.T_base_optical, view.detections, stamp=T0 + i), SESSION.camera)
    return live


def test_estimate_outputs_and_reset() -> None:
    live = _fed_session()
    out = live.estimate()
    assert len(out.detections.detections) == 1 and out.detections.detections[0].id == "0"
    assert out.detections.header.frame_id == "base"
    assert out.detections.header.stamp.sec == int(T0 + 2)  # the latest view's stamp
    s = out.status
    assert (s["event"], s["views"], s["views_in_estimate"], s["fruit"]) == ("estimate", 3, 3, 1)
    assert s["tracks"][0]["label"] == "tomato" and s["tracks"][0]["views"] == 3
    live.reset()
    assert live.status("reset")["views"] == 0 and live.estimate() is None
    live.add(SESSION.views[0], SESSION.camera)
    assert live.status("reset")["session"] == 2


def test_a_changed_camera_is_refused_until_a_reset() -> None:
    live = _fed_session()
    other = SESSION.camera.scaled(320, 240)
    assert not live.add(SESSION.views[0], other)
    status = live.status("dropped")
    assert status["views"] == 3 and status["views_dropped"] == 1
    assert "CameraInfo differs from the session's first one" in status["dropped"][0]["reason"]
    live.reset()
    assert live.add(SESSION.views[0], other)


def test_the_status_carries_verdict_and_warnings_when_the_method_gives_them(monkeypatch: pytest.MonkeyPatch) -> None:
    """``localizer.last.quality`` and ``.warnings`` are read, each warning once."""
    real = BayesLocalizer.estimate

    def estimate(self):  # noqa: ANN001, ANN202
        objects = real(self)
        self.last = replace(self.last, quality={"verdict": "suspect", "causes": ["few views"]}, warnings=["w1"])
        return objects

    live = _fed_session()
    assert live.estimate().status["verdict"] == "ok"  # a clean session: the quality model found nothing
    monkeypatch.setattr(BayesLocalizer, "estimate", estimate)
    s = live.estimate().status
    assert (s["verdict"], s["causes"]) == ("suspect", ["few views"]) and s["warnings"].count("w1") == 1
