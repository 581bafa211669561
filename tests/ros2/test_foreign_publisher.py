"""A ROS 2 publisher the project did not write: its own DDS types, its bytes serialised by ``rosbags``.

The types below are written here from the ROS 2 message definitions (ROS 2's DDS type names, none of the
package's classes); every message is built and serialised by ``rosbags`` with its ROS 2 Humble definitions (and
the vision_msgs 4.x ones of ``ros_reference.py``), and those bytes are what goes on the wire. The node localises
the built-in example session from them.
"""

# no ``from __future__ import annotations``: cyclonedds reads the field types of the classes below at run time
import os
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")
typesys = pytest.importorskip("rosbags.typesys", reason="needs rosbags (pip install 'monovisual3d[ros]')")

from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import IdlStruct  # noqa: E402
from cyclonedds.idl.types import array, float64, int32, sequence, uint32  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.qos import Policy, Qos  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from dds_helpers import Collector, running_node, topics  # noqa: E402
from numpy.testing import assert_allclose  # noqa: E402
from ros_reference import VISION_MSGS_4  # noqa: E402

from monovisual3d.api import localize  # noqa: E402
from monovisual3d.examples import example_session_path  # noqa: E402
from monovisual3d.frames import position_quaternion_from_transform  # noqa: E402
from monovisual3d.ros2.config import NodeConfig  # noqa: E402
from monovisual3d.session.load import load_session  # noqa: E402


# ----------------------------------------------------------------------------- the publisher's own types
@dataclass
class Stamp(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Hdr(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Stamp = field(default_factory=Stamp)
    frame_id: str = ""


@dataclass
class P2(IdlStruct, typename="vision_msgs::msg::dds_::Point2D_"):
    x: float64 = 0.0
    y: float64 = 0.0


@dataclass
class Pose2(IdlStruct, typename="vision_msgs::msg::dds_::Pose2D_"):
    position: P2 = field(default_factory=P2)
    theta: float64 = 0.0


@dataclass
class Box2(IdlStruct, typename="vision_msgs::msg::dds_::BoundingBox2D_"):
    center: Pose2 = field(default_factory=Pose2)
    size_x: float64 = 0.0
    size_y: float64 = 0.0


@dataclass
class Hyp(IdlStruct, typename="vision_msgs::msg::dds_::ObjectHypothesis_"):
    class_id: str = ""
    score: float64 = 0.0


@dataclass
class P3(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class V3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Q(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
class Pose3(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: P3 = field(default_factory=P3)
    orientation: Q = field(default_factory=Q)


@dataclass
class PoseCov(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose3 = field(default_factory=Pose3)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class HypPose(IdlStruct, typename="vision_msgs::msg::dds_::ObjectHypothesisWithPose_"):
    hypothesis: Hyp = field(default_factory=Hyp)
    pose: PoseCov = field(default_factory=PoseCov)


@dataclass
class Det2(IdlStruct, typename="vision_msgs::msg::dds_::Detection2D_"):
    header: Hdr = field(default_factory=Hdr)
    results: sequence[HypPose] = field(default_factory=list)
    bbox: Box2 = field(default_factory=Box2)
    id: str = ""


@dataclass
class Det2Array(IdlStruct, typename="vision_msgs::msg::dds_::Detection2DArray_"):
    header: Hdr = field(default_factory=Hdr)
    detections: sequence[Det2] = field(default_factory=list)


@dataclass
class Roi(IdlStruct, typename="sensor_msgs::msg::dds_::RegionOfInterest_"):
    x_offset: uint32 = 0
    y_offset: uint32 = 0
    height: uint32 = 0
    width: uint32 = 0
    do_rectify: bool = False


@dataclass
class Info(IdlStruct, typename="sensor_msgs::msg::dds_::CameraInfo_"):
    header: Hdr = field(default_factory=Hdr)
    height: uint32 = 0
    width: uint32 = 0
    distortion_model: str = ""
    d: sequence[float64] = field(default_factory=list)
    k: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    r: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    p: array[float64, 12] = field(default_factory=lambda: [0.0] * 12)
    binning_x: uint32 = 0
    binning_y: uint32 = 0
    roi: Roi = field(default_factory=Roi)


@dataclass
class Tr(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: V3 = field(default_factory=V3)
    rotation: Q = field(default_factory=Q)


@dataclass
class TrStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Hdr = field(default_factory=Hdr)
    child_frame_id: str = ""
    transform: Tr = field(default_factory=Tr)


@dataclass
class Tf(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TrStamped] = field(default_factory=list)


# ----------------------------------------------------------------------------- messages built by rosbags
def _store() -> Any:
    store = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
    types: dict[str, Any] = {}
    for name, text in VISION_MSGS_4.items():
        types.update(typesys.get_types_from_msg(text, name))
    store.register(types)
    return store


def _header(store: Any, frame: str, stamp: float) -> Any:
    sec, frac = divmod(stamp, 1.0)
    return store.types["std_msgs/msg/Header"](
        stamp=store.types["builtin_interfaces/msg/Time"](sec=int(sec), nanosec=int(round(frac * 1e9))), frame_id=frame
    )


def _camera_info(store: Any, camera: Any, stamp: float) -> bytes:
    K = camera.opencv_matrix()
    msg = store.types["sensor_msgs/msg/CameraInfo"](
        header=_header(store, "cam_optical", stamp),
        height=camera.height,
        width=camera.width,
        distortion_model="plumb_bob",
        d=np.zeros(5),
        k=K.ravel(),
        r=np.eye(3).ravel(),
        p=np.hstack([K, np.zeros((3, 1))]).ravel(),
        binning_x=0,
        binning_y=0,
        roi=store.types["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
    )
    return bytes(store.serialize_cdr(msg, "sensor_msgs/msg/CameraInfo"))


def _detections(store: Any, view: Any, stamp: float) -> bytes:
    T = store.types
    pose = T["geometry_msgs/msg/PoseWithCovariance"](
        pose=T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        ),
        covariance=np.zeros(36),
    )
    dets = []
    for (x1, y1, x2, y2), det in zip(view.boxes_xyxy, view.detections, strict=True):
        hyp = T["vision_msgs/msg/ObjectHypothesisWithPose"](
            hypothesis=T["vision_msgs/msg/ObjectHypothesis"](class_id=det.label or "", score=0.9), pose=pose
        )
        centre = T["vision_msgs/msg/Pose2D"](position=T["vision_msgs/msg/Point2D"](x=(x1 + x2) / 2, y=(y1 + y2) / 2), theta=0.0)
        bbox = T["vision_msgs/msg/BoundingBox2D"](center=centre, size_x=x2 - x1, size_y=y2 - y1)
        dets.append(
            T["vision_msgs/msg/Detection2D"](header=_header(store, "cam_optical", stamp), results=[hyp], bbox=bbox, id="")
        )
    msg = T["vision_msgs/msg/Detection2DArray"](header=_header(store, "cam_optical", stamp), detections=dets)
    return bytes(store.serialize_cdr(msg, "vision_msgs/msg/Detection2DArray"))


def _tf(store: Any, T_base_cam: np.ndarray, stamp: float) -> bytes:
    T = store.types
    p, q = position_quaternion_from_transform(T_base_cam)
    transform = T["geometry_msgs/msg/Transform"](
        translation=T["geometry_msgs/msg/Vector3"](x=p[0], y=p[1], z=p[2]),
        rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
    )
    tr = T["geometry_msgs/msg/TransformStamped"](
        header=_header(store, "base_link", stamp), child_frame_id="cam_optical", transform=transform
    )
    return bytes(store.serialize_cdr(T["tf2_msgs/msg/TFMessage"](transforms=[tr]), "tf2_msgs/msg/TFMessage"))


def _raw(cls: type, data: bytes) -> Any:
    """An instance of ``cls`` whose serialisation is ``data`` (the writer sends these bytes as they are)."""
    sample = cls()
    sample.serialize = lambda **_: data  # type: ignore[method-assign]
    return sample


def test_the_node_localises_from_a_foreign_publisher() -> None:
    session = load_session(example_session_path())
    store = _store()
    t = topics("foreign")
    out = Collector(t)
    dp = DomainParticipant(int(os.environ["ROS_DOMAIN_ID"]))
    # rclpy's default publisher QoS (reliable, volatile, keep last 10); tf2's broadcaster: keep last 100
    qos = Qos(Policy.Reliability.Reliable(max_blocking_time=10**9), Policy.Durability.Volatile, Policy.History.KeepLast(10))
    writers = {
        cls: DataWriter(dp, Topic(dp, "rt" + name, cls), qos=qos)
        for cls, name in ((Info, t.camera_info), (Det2Array, t.detections), (Tf, t.tf))
    }
    try:
        with running_node(NodeConfig(topics=t, warmup=False)):
            deadline = time.monotonic() + 10
            while not writers[Det2Array].get_matched_subscriptions() and time.monotonic() < deadline:
                time.sleep(0.05)
            time.sleep(0.3)
            t0 = time.time()
            for i, view in enumerate(session.views):
                stamp = t0 + 0.2 * i
                for dt in (-0.05, 0.05):  # the arm at rest for the picture: two samples, the same pose
                    writers[Tf].write(_raw(Tf, _tf(store, view.T_base_optical, stamp + dt)))
                writers[Info].write(_raw(Info, _camera_info(store, session.camera, stamp)))
                writers[Det2Array].write(_raw(Det2Array, _detections(store, view, stamp)))
                time.sleep(0.2)
            assert out.wait_for(lambda c: (c.last("estimate") or {}).get("views") == 3)
        assert out.last("estimate")["views_dropped"] == 0
        (fruit,) = out.detections[-1].detections
        p = fruit.bbox.center.position
        assert_allclose([p.x, p.y, p.z], localize(session).objects[0].position, atol=1e-4)
        assert (fruit.results[0].hypothesis.class_id, fruit.results[0].hypothesis.score) == ("tomato", pytest.approx(0.9))
    finally:
        out.close()
        dp.__del__()
