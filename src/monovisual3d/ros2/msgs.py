"""The ROS 2 messages the node reads and writes, as Cyclone DDS types (extra ``[ros2]``).

Each class is the DDS form of one ROS 2 message, field for field in the order of its ``.msg`` file, under
the DDS type name ROS 2 gives it (``pkg::msg::dds_::Name_``, :func:`.names.dds_type`). They are ``final``
structs, serialised as plain CDR (XCDR1, little-endian encapsulation ``00 01 00 00``) exactly as
``rmw_cyclonedds_cpp`` and ``rmw_fastrtps_cpp`` serialise messages: the tests compare their bytes with
``rosbags``' serialisation of the ROS 2 Humble and Jazzy definitions (``tests/ros2/test_wire.py``).
vision_msgs is that of Humble and Jazzy (4.x). Field values default to those of ROS 2 (zeros, empty
strings and sequences, the identity quaternion).

:data:`MESSAGE_TYPES` maps each ROS 2 type name (``std_msgs/msg/Header``) to its class.
"""

# no ``from __future__ import annotations`` here: cyclonedds reads the field types of these classes at run time
from dataclasses import dataclass, field

from .._extras import require

_idl = require("cyclonedds.idl", "ros2")
_t = require("cyclonedds.idl.types", "ros2")

IdlStruct = _idl.IdlStruct
float32, float64, int32, uint8, uint32 = _t.float32, _t.float64, _t.int32, _t.uint8, _t.uint32
array, sequence = _t.array, _t.sequence


def _name(package: str, name: str) -> str:
    return f"{package}::msg::dds_::{name}_"


# --------------------------------------------------------------------------- builtin_interfaces, std_msgs
@dataclass
class Time(IdlStruct, typename=_name("builtin_interfaces", "Time")):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Duration(IdlStruct, typename=_name("builtin_interfaces", "Duration")):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Header(IdlStruct, typename=_name("std_msgs", "Header")):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class String(IdlStruct, typename=_name("std_msgs", "String")):
    data: str = ""


@dataclass
class Empty(IdlStruct, typename=_name("std_msgs", "Empty")):
    # ROS 2 gives an empty message this one member, as IDL has no empty struct
    structure_needs_at_least_one_member: uint8 = 0


@dataclass
class ColorRGBA(IdlStruct, typename=_name("std_msgs", "ColorRGBA")):
    r: float32 = 0.0
    g: float32 = 0.0
    b: float32 = 0.0
    a: float32 = 0.0


# --------------------------------------------------------------------------- geometry_msgs, tf2_msgs
@dataclass
class Point(IdlStruct, typename=_name("geometry_msgs", "Point")):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Vector3(IdlStruct, typename=_name("geometry_msgs", "Vector3")):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename=_name("geometry_msgs", "Quaternion")):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
class Pose(IdlStruct, typename=_name("geometry_msgs", "Pose")):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class PoseStamped(IdlStruct, typename=_name("geometry_msgs", "PoseStamped")):
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass
class PoseWithCovariance(IdlStruct, typename=_name("geometry_msgs", "PoseWithCovariance")):
    pose: Pose = field(default_factory=Pose)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class Transform(IdlStruct, typename=_name("geometry_msgs", "Transform")):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename=_name("geometry_msgs", "TransformStamped")):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, typename=_name("tf2_msgs", "TFMessage")):
    transforms: sequence[TransformStamped] = field(default_factory=list)


# --------------------------------------------------------------------------- sensor_msgs
@dataclass
class RegionOfInterest(IdlStruct, typename=_name("sensor_msgs", "RegionOfInterest")):
    x_offset: uint32 = 0
    y_offset: uint32 = 0
    height: uint32 = 0
    width: uint32 = 0
    do_rectify: bool = False


@dataclass
class CameraInfo(IdlStruct, typename=_name("sensor_msgs", "CameraInfo")):
    header: Header = field(default_factory=Header)
    height: uint32 = 0
    width: uint32 = 0
    distortion_model: str = ""
    d: sequence[float64] = field(default_factory=list)
    k: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    r: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    p: array[float64, 12] = field(default_factory=lambda: [0.0] * 12)
    binning_x: uint32 = 0
    binning_y: uint32 = 0
    roi: RegionOfInterest = field(default_factory=RegionOfInterest)


@dataclass
class CompressedImage(IdlStruct, typename=_name("sensor_msgs", "CompressedImage")):
    header: Header = field(default_factory=Header)
    format: str = ""
    data: sequence[uint8] = field(default_factory=list)


# --------------------------------------------------------------------------- vision_msgs 4.x
@dataclass
class Point2D(IdlStruct, typename=_name("vision_msgs", "Point2D")):
    x: float64 = 0.0
    y: float64 = 0.0


@dataclass
class Pose2D(IdlStruct, typename=_name("vision_msgs", "Pose2D")):
    position: Point2D = field(default_factory=Point2D)
    theta: float64 = 0.0


@dataclass
class BoundingBox2D(IdlStruct, typename=_name("vision_msgs", "BoundingBox2D")):
    center: Pose2D = field(default_factory=Pose2D)
    size_x: float64 = 0.0
    size_y: float64 = 0.0


@dataclass
class BoundingBox3D(IdlStruct, typename=_name("vision_msgs", "BoundingBox3D")):
    center: Pose = field(default_factory=Pose)
    size: Vector3 = field(default_factory=Vector3)


@dataclass
class ObjectHypothesis(IdlStruct, typename=_name("vision_msgs", "ObjectHypothesis")):
    class_id: str = ""
    score: float64 = 0.0


@dataclass
class ObjectHypothesisWithPose(IdlStruct, typename=_name("vision_msgs", "ObjectHypothesisWithPose")):
    hypothesis: ObjectHypothesis = field(default_factory=ObjectHypothesis)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@dataclass
class Detection2D(IdlStruct, typename=_name("vision_msgs", "Detection2D")):
    header: Header = field(default_factory=Header)
    results: sequence[ObjectHypothesisWithPose] = field(default_factory=list)
    bbox: BoundingBox2D = field(default_factory=BoundingBox2D)
    id: str = ""


@dataclass
class Detection2DArray(IdlStruct, typename=_name("vision_msgs", "Detection2DArray")):
    header: Header = field(default_factory=Header)
    detections: sequence[Detection2D] = field(default_factory=list)


@dataclass
class Detection3D(IdlStruct, typename=_name("vision_msgs", "Detection3D")):
    header: Header = field(default_factory=Header)
    results: sequence[ObjectHypothesisWithPose] = field(default_factory=list)
    bbox: BoundingBox3D = field(default_factory=BoundingBox3D)
    id: str = ""


@dataclass
class Detection3DArray(IdlStruct, typename=_name("vision_msgs", "Detection3DArray")):
    header: Header = field(default_factory=Header)
    detections: sequence[Detection3D] = field(default_factory=list)


# --------------------------------------------------------------------------- visualization_msgs
@dataclass
class UVCoordinate(IdlStruct, typename=_name("visualization_msgs", "UVCoordinate")):
    u: float32 = 0.0
    v: float32 = 0.0


@dataclass
class MeshFile(IdlStruct, typename=_name("visualization_msgs", "MeshFile")):
    filename: str = ""
    data: sequence[uint8] = field(default_factory=list)


@dataclass
class Marker(IdlStruct, typename=_name("visualization_msgs", "Marker")):
    """``visualization_msgs/Marker`` (Humble and Jazzy: the same fields; Jazzy adds the constant ARROW_STRIP)."""

    header: Header = field(default_factory=Header)
    ns: str = ""
    id: int32 = 0
    type: int32 = 0
    action: int32 = 0
    pose: Pose = field(default_factory=Pose)
    scale: Vector3 = field(default_factory=Vector3)
    color: ColorRGBA = field(default_factory=ColorRGBA)
    lifetime: Duration = field(default_factory=Duration)
    frame_locked: bool = False
    points: sequence[Point] = field(default_factory=list)
    colors: sequence[ColorRGBA] = field(default_factory=list)
    texture_resource: str = ""
    texture: CompressedImage = field(default_factory=CompressedImage)
    uv_coordinates: sequence[UVCoordinate] = field(default_factory=list)
    text: str = ""
    mesh_resource: str = ""
    mesh_file: MeshFile = field(default_factory=MeshFile)
    mesh_use_embedded_materials: bool = False


@dataclass
class MarkerArray(IdlStruct, typename=_name("visualization_msgs", "MarkerArray")):
    markers: sequence[Marker] = field(default_factory=list)


#: Marker.type and Marker.action values used here (visualization_msgs/Marker constants).
MARKER_SPHERE, MARKER_TEXT_VIEW_FACING = 2, 9
MARKER_ADD, MARKER_DELETEALL = 0, 3

_CLASSES = (
    Time,
    Duration,
    Header,
    String,
    Empty,
    ColorRGBA,
    Point,
    Vector3,
    Quaternion,
    Pose,
    PoseStamped,
    PoseWithCovariance,
    Transform,
    TransformStamped,
    TFMessage,
    RegionOfInterest,
    CameraInfo,
    CompressedImage,
    Point2D,
    Pose2D,
    BoundingBox2D,
    BoundingBox3D,
    ObjectHypothesis,
    ObjectHypothesisWithPose,
    Detection2D,
    Detection2DArray,
    Detection3D,
    Detection3DArray,
    UVCoordinate,
    MeshFile,
    Marker,
    MarkerArray,
)


def _ros_name(cls: type) -> str:
    package, _, _, name = cls.__idl_typename__.split("::")
    return f"{package}/msg/{name[:-1]}"


#: ROS 2 type name (``pkg/msg/Name``) -> message class.
MESSAGE_TYPES: dict[str, type] = {_ros_name(c): c for c in _CLASSES}

#: ROS 2 type hashes (REP 2011, ``RIHS01``, Iron and later) of the messages on the node's topics. ROS 2's middlewares
#: put ``typehash=...;`` in each endpoint's USER_DATA, which ``ros2 topic info -v`` shows; the node does the same.
#: The tests check each against ``rosbags``' ``hash_rihs01`` of the Jazzy definitions.
TYPE_HASHES: dict[str, str] = {
    "std_msgs/msg/String": "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
    "std_msgs/msg/Empty": "RIHS01_20b625256f32d5dbc0d04fee44f43c41e51c70d3502f84b4a08e7a9c26a96312",
    "sensor_msgs/msg/CameraInfo": "RIHS01_b3dfd68ff46c9d56c80fd3bd4ed22c7a4ddce8c8348f2f59c299e73118e7e275",
    "tf2_msgs/msg/TFMessage": "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
    "vision_msgs/msg/Detection2DArray": "RIHS01_214274120007f4a683866481336b70310268cfa107aebe9d594a6acf75bda968",
    "vision_msgs/msg/Detection3DArray": "RIHS01_793f5eab9595ac1c0da07873cc859db42eae51f0ee76056db8562515d830e018",
    "visualization_msgs/msg/MarkerArray": "RIHS01_86cb8800b6fb05b5eff1abd7a56f62a5641d3ae9a1c29e78e67e704f1d067dcf",
    "geometry_msgs/msg/PoseStamped": "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
}


def user_data(cls: type) -> bytes:
    """The USER_DATA a ROS 2 (Iron or later) endpoint of ``cls`` carries: ``typehash=RIHS01_...;`` (empty if unknown)."""
    h = TYPE_HASHES.get(_ros_name(cls))
    return f"typehash={h};".encode() if h else b""


__all__ = [
    "MARKER_ADD",
    "MARKER_DELETEALL",
    "MARKER_SPHERE",
    "MARKER_TEXT_VIEW_FACING",
    "MESSAGE_TYPES",
    *(c.__name__ for c in _CLASSES),
]
