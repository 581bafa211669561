"""``monovisual3d ros2 play``: publish a session as a robot would, for demos and tests without a robot.

Per view ``i`` of the session, at stamp ``t_i = t_0 + i / rate``: a ``sensor_msgs/CameraInfo`` and a
``vision_msgs/Detection2DArray`` (frame ``camera_frame``, the boxes as detected), published at ``t_i``. The camera
pose reaches TF as a moving transform ``base_frame -> tool_frame`` plus a static one ``tool_frame ->
camera_frame`` (``T_tool_camera``, on ``/tf_static``, transient local). The moving transform is sampled every
``tf_period_s`` on a grid offset by half a period from the first view's stamp, so the node must interpolate
between two samples to get a view's pose; around each view the tool moves at a constant linear and angular speed
(:data:`SPEED_M_S`, :data:`TURN_RAD_S`), so that interpolation (linear + slerp) gives the view's pose exactly and
taking the nearest sample would not. Between views the tool moves along the geodesic. Each TF sample is
published ``tf_delay_s`` after its stamp (a TF arriving late).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from ..camera import Camera
from ..errors import InputError
from ..frames import invert_transform, position_quaternion_from_transform, transform_from_position_quaternion
from ..io.ros_messages import NS_PER_S, stamp_ns
from ..session import Session
from . import dds, msgs
from .config import Topics
from .outputs import header

#: Linear speed of the camera around a view, m/s, and its turning rate, rad/s (a slow arm).
SPEED_M_S, TURN_RAD_S = 0.1, 0.2
#: Default hand-eye transform of the player: the optical frame 8 cm ahead of the tool flange, turned 10 degrees.
DEFAULT_T_TOOL_CAMERA = transform_from_position_quaternion(
    [0.0, 0.03, 0.08], Rotation.from_euler("x", 10, degrees=True).as_quat()
)
#: TF samples published before the first view and after the last (the node can interpolate at both ends).
TF_MARGIN = 3
#: Seconds the player waits after its last message, so that reliable samples are delivered before it exits.
LINGER_S = 1.0


@dataclass(frozen=True)
class PlayConfig:
    """Options of the player.

    Attributes
    ----------
    topics : Topics, the input topics of the node (camera_info, detections, tf, tf_static) are published
    rate_hz : float, views per second
    base_frame, tool_frame, camera_frame : str, the TF frames (the camera frame is an optical frame)
    T_tool_camera : ndarray, shape (4, 4), the static transform tool -> camera (optical)
    tf_period_s : float, seconds between TF samples
    tf_delay_s : float, seconds between a TF sample's stamp and its publication
    sensor_qos : bool, publish detections and camera info best effort (``SensorDataQoS``) instead of reliable
    wait_s : float, seconds to wait for a subscriber of the detections before the first view (0: do not wait)
    domain_id : int or None, DDS domain (None: ``ROS_DOMAIN_ID``)
    """

    topics: Topics = field(default_factory=Topics)
    rate_hz: float = 1.0
    base_frame: str = "base_link"
    tool_frame: str = "tool0"
    camera_frame: str = "camera_optical_frame"
    T_tool_camera: NDArray[np.float64] = field(default_factory=lambda: DEFAULT_T_TOOL_CAMERA.copy())
    tf_period_s: float = 0.1
    tf_delay_s: float = 0.0
    sensor_qos: bool = False
    wait_s: float = 10.0
    domain_id: int | None = None

    def __post_init__(self) -> None:
        for name in ("rate_hz", "tf_period_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise InputError(f"{name}: got {v!r}, expected a positive number")
        for name in ("tf_delay_s", "wait_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise InputError(f"{name}: got {v!r}, expected a number >= 0")


# ----------------------------------------------------------------------------- messages of a session
def camera_info_msg(camera: Camera, frame_id: str, stamp_ns: int) -> msgs.CameraInfo:
    """``sensor_msgs/CameraInfo`` of a camera (OpenCV pixel convention, as ROS; no distortion: plumb_bob zeros)."""
    K = camera.opencv_matrix()
    model = camera.distortion_model if camera.distortion_model != "none" else "plumb_bob"
    d = list(camera.distortion_coefficients) if camera.distortion_model != "none" else [0.0] * 5
    P = np.hstack([K, np.zeros((3, 1))])
    return msgs.CameraInfo(
        header=header(frame_id, stamp_ns),
        height=camera.height,
        width=camera.width,
        distortion_model=model,
        d=[float(v) for v in d],
        k=[float(v) for v in K.ravel()],
        r=[float(v) for v in np.eye(3).ravel()],
        p=[float(v) for v in P.ravel()],
    )


def detection2d_array_msg(
    boxes_xyxy: NDArray[np.float64], labels: Sequence[str | None], scores: Sequence[float | None], frame_id: str, stamp_ns: int
) -> msgs.Detection2DArray:
    """``vision_msgs/Detection2DArray`` of boxes (N, 4), pixels; one hypothesis per box when it has a label or score."""
    hdr = header(frame_id, stamp_ns)
    out = []
    for (x1, y1, x2, y2), label, score in zip(np.asarray(boxes_xyxy, dtype=float).reshape(-1, 4), labels, scores, strict=True):
        results = []
        if label is not None or score is not None:
            hyp = msgs.ObjectHypothesis(class_id=label or "", score=1.0 if score is None else float(score))
            results.append(msgs.ObjectHypothesisWithPose(hypothesis=hyp))
        centre = msgs.Pose2D(position=msgs.Point2D(x=0.5 * (x1 + x2), y=0.5 * (y1 + y2)))
        bbox = msgs.BoundingBox2D(center=centre, size_x=float(x2 - x1), size_y=float(y2 - y1))
        out.append(msgs.Detection2D(header=hdr, results=results, bbox=bbox))
    return msgs.Detection2DArray(header=hdr, detections=out)


def tf_message(parent: str, child: str, T_parent_child: NDArray[np.float64], stamp_ns: int) -> msgs.TFMessage:
    """``tf2_msgs/TFMessage`` with one transform."""
    p, q = position_quaternion_from_transform(T_parent_child)
    transform = msgs.Transform(
        translation=msgs.Vector3(x=float(p[0]), y=float(p[1]), z=float(p[2])),
        rotation=msgs.Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])),
    )
    return msgs.TFMessage(
        transforms=[msgs.TransformStamped(header=header(parent, stamp_ns), child_frame_id=child, transform=transform)]
    )


# ----------------------------------------------------------------------------- the camera's trajectory
def _moved(T: NDArray[np.float64], dt: float, direction: NDArray[np.float64], axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """``T`` after ``dt`` seconds at :data:`SPEED_M_S` along ``direction`` and :data:`TURN_RAD_S` about ``axis`` (base frame)."""
    out = T.copy()
    out[:3, :3] = Rotation.from_rotvec(axis * TURN_RAD_S * dt).as_matrix() @ T[:3, :3]
    out[:3, 3] = T[:3, 3] + direction * SPEED_M_S * dt
    return out


def trajectory(
    poses: Sequence[NDArray[np.float64]], times: Sequence[float], period_s: float
) -> Callable[[float], NDArray[np.float64]]:
    """``T(t)`` through ``poses`` at ``times``: a constant twist within ``period_s`` of each time, the geodesic between.

    Within a window, linear + slerp interpolation between any two samples of ``T`` gives ``T`` exactly (the moving
    frame's origin moves on a line, its rotation turns about a fixed axis at a constant rate).
    """
    stamps = np.asarray(times, dtype=float)
    rng = np.random.default_rng(0)  # fixed directions of motion: a deterministic trajectory
    dirs = [d / np.linalg.norm(d) for d in rng.normal(size=(len(stamps), 3))]
    axes = [a / np.linalg.norm(a) for a in rng.normal(size=(len(stamps), 3))]

    def window(i: int, dt: float) -> NDArray[np.float64]:
        return _moved(poses[i], float(np.clip(dt, -period_s, period_s)), dirs[i], axes[i])

    def pose(t: float) -> NDArray[np.float64]:
        j = int(np.argmin(np.abs(stamps - t)))  # the nearest view
        if abs(t - stamps[j]) <= period_s or t < stamps[0] or t > stamps[-1]:
            return window(j, t - stamps[j])
        i = int(np.searchsorted(stamps, t, side="right")) - 1  # stamps[i] <= t < stamps[i + 1], outside both windows
        a, b = window(i, period_s), window(i + 1, -period_s)
        s = (t - stamps[i] - period_s) / (stamps[i + 1] - stamps[i] - 2 * period_s)
        out = np.eye(4)
        delta = Rotation.from_matrix(b[:3, :3] @ a[:3, :3].T).as_rotvec()
        out[:3, :3] = Rotation.from_rotvec(s * delta).as_matrix() @ a[:3, :3]
        out[:3, 3] = (1 - s) * a[:3, 3] + s * b[:3, 3]
        return out

    return pose


# ----------------------------------------------------------------------------- the schedule
def schedule(session: Session, config: PlayConfig, t0: float) -> list[tuple[float, int, str, Any]]:
    """Every message of the session: ``(wall time, order, topic, message)``, sorted by wall time (seconds since the epoch).

    One unit of thought: the views' messages and the TF samples around them form one time line.
    """
    n = len(session.views)
    stamps = [t0 + i / config.rate_hz for i in range(n)]
    T_camera_tool = invert_transform(config.T_tool_camera)
    T_base_tool = trajectory([v.T_base_optical @ T_camera_tool for v in session.views], stamps, config.tf_period_s)
    t = config.topics
    events: list[tuple[float, int, str, Any]] = []
    for i, (view, stamp) in enumerate(zip(session.views, stamps, strict=True)):
        ns = int(round(stamp * NS_PER_S))
        dets = view.detections
        boxes = view.boxes_xyxy
        events.append((stamp, 2 * i, t.camera_info, camera_info_msg(session.camera, config.camera_frame, ns)))
        msg = detection2d_array_msg(boxes, [d.label for d in dets], [d.score for d in dets], config.camera_frame, ns)
        events.append((stamp, 2 * i + 1, t.detections, msg))
    period = config.tf_period_s
    n_samples = math.ceil((stamps[-1] - stamps[0]) / period) + 2 * TF_MARGIN + 1
    for k in range(n_samples):  # a grid half a period off the first view's stamp, TF_MARGIN samples beyond the views
        s = stamps[0] + (k - TF_MARGIN - 0.5) * period
        msg = tf_message(config.base_frame, config.tool_frame, T_base_tool(s), int(round(s * NS_PER_S)))
        events.append((s + config.tf_delay_s, 2 * n + k, t.tf, msg))
    return sorted(events, key=lambda e: (e[0], e[1]))


def play_session(session: Session, config: PlayConfig, log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Publish the session (see the module docstring); what was published, as a dict.

    Waits up to ``config.wait_s`` for a subscriber of the detections before the first view. The dict has ``views``,
    ``messages``, ``domain_id``, ``subscriber`` (whether one was there) and ``published``: ``(wall time, topic,
    stamp_ns)`` of every message as it was written (TF: the stamp of its transform).
    """
    if not session.views:
        raise InputError(f"{session.source or 'session'}: no views to play")
    log = log or (lambda line: None)
    domain = config.domain_id if config.domain_id is not None else dds.domain_id_from_env()
    dp = dds.participant(domain)
    try:
        return _play(session, config, dds.Endpoints(dp), domain, log)
    finally:
        dp.__del__()  # leave the domain now, not at garbage collection


def _play(session: Session, config: PlayConfig, ep: dds.Endpoints, domain: int, log: Callable[[str], None]) -> dict[str, Any]:
    """The body of :func:`play_session`: the writers, the wait for a subscriber, the schedule."""
    sensor = dds.publisher_qos("sensor" if config.sensor_qos else "default")
    t = config.topics
    writers = {
        t.camera_info: ep.writer(t.camera_info, msgs.CameraInfo, sensor),
        t.detections: ep.writer(t.detections, msgs.Detection2DArray, sensor),
        t.tf: ep.writer(t.tf, msgs.TFMessage, dds.publisher_qos("tf")),
    }
    static = ep.writer(t.tf_static, msgs.TFMessage, dds.publisher_qos("tf_static"))
    static.write(tf_message(config.tool_frame, config.camera_frame, config.T_tool_camera, int(time.time() * NS_PER_S)))
    matched = _wait_for_subscriber(writers[t.detections], config.wait_s)
    log(
        f"domain {domain}: {'a subscriber' if matched else 'no subscriber'} on {t.detections}; playing {len(session.views)} views at {config.rate_hz:g} Hz"
    )
    events = schedule(session, config, time.time() + TF_MARGIN * config.tf_period_s)
    published = []
    for when, _, topic, msg in events:
        delay = when - time.time()
        if delay > 0:
            time.sleep(delay)
        writers[topic].write(msg)
        published.append((time.time(), topic, stamp_ns(msg.transforms[0].header.stamp if topic == t.tf else msg.header.stamp)))
    time.sleep(LINGER_S)
    return {
        "views": len(session.views),
        "messages": len(events),
        "domain_id": domain,
        "subscriber": matched,
        "published": published,
    }


def _wait_for_subscriber(writer: Any, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while True:
        if writer.get_matched_subscriptions():
            time.sleep(0.2)  # the other readers of the same node are matched at about the same time
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.05)


__all__ = [
    "PlayConfig",
    "camera_info_msg",
    "trajectory",
    "detection2d_array_msg",
    "play_session",
    "schedule",
    "tf_message",
]
