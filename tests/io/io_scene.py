"""A small synthetic scene for the io tests: three spheres seen by a distorted camera from four poses.

Boxes come from :func:`monovisual3d.geometry.sphere.sphere_bbox` (exact silhouettes), so a
session built directly from these poses is the reference that every importer
must reproduce.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from monovisual3d import Camera, localize
from monovisual3d.frames import look_at
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.session import Session
from monovisual3d.session.load import session_from_dict

#: OpenCV-convention intrinsics (pixel centres at integers) and mild plumb_bob distortion.
K_OPENCV = np.array([[462.5, 0.0, 319.25], [0.0, 463.0, 241.75], [0.0, 0.0, 1.0]])
D_PLUMB_BOB = (0.04, -0.08, 0.001, -0.0007, 0.02)
CAMERA = Camera.from_opencv(K_OPENCV, 640, 480, "plumb_bob", D_PLUMB_BOB)

CENTRES = np.array([[0.60, -0.05, 0.42], [0.64, 0.06, 0.47], [0.57, 0.02, 0.53]])
RADII = np.array([0.030, 0.035, 0.028])
LABELS = ("tomato", "tomato", "tomato")
WORKSPACE = {"min": [0.45, -0.15, 0.32], "max": [0.75, 0.15, 0.62]}
LOCALIZE_OPTIONS: dict[str, Any] = {"method": "paper", "resolution": 0.01}
#: Stamps (seconds) at which the images are taken: realistic epoch times.
T0 = 1_700_000_000.0


def camera_positions() -> np.ndarray:
    """Camera centres, shape (4, 3), metres, base frame: four directions around the fruit."""
    target = CENTRES.mean(axis=0)
    dirs = np.array([[-1.0, 0.0, 0.1], [-0.6, 0.75, 0.2], [-0.6, -0.7, 0.35], [-0.55, 0.2, 0.8]])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    return target + 0.42 * dirs


def camera_poses() -> list[np.ndarray]:
    """``T_base_optical`` of the four views, each looking at the fruit's centroid."""
    target = CENTRES.mean(axis=0)
    return [look_at(p, target) for p in camera_positions()]


def view_boxes(camera: Camera, T_base_optical: np.ndarray) -> list[np.ndarray]:
    """Boxes of the spheres visible in a view, pixels; all must be visible for this scene."""
    boxes = sphere_bbox(camera, T_base_optical, CENTRES, RADII)
    assert np.all(np.isfinite(boxes)), "test scene: every sphere must be in every view"
    return list(boxes)


def scores() -> list[float]:
    return [0.91, 0.84, 0.77]


def direct_session_dict(camera: Camera = CAMERA, poses: list[np.ndarray] | None = None) -> dict[str, Any]:
    """The reference session dict (poses as matrices, optical frame)."""
    poses = camera_poses() if poses is None else poses
    views = []
    for i, T in enumerate(poses):
        dets = [{"bbox_xyxy": b.tolist(), "score": s, "label": lab} for b, s, lab in zip(view_boxes(camera, T), scores(), LABELS)]
        views.append({"pose": {"matrix": T.tolist()}, "detections": dets, "image": f"img_{i:03d}.png", "stamp": T0 + i})
    return {"camera": camera.to_dict(), "views": views, "workspace": WORKSPACE}


def direct_session() -> Session:
    return session_from_dict(direct_session_dict())


def localize_positions(session: Session | dict[str, Any]) -> np.ndarray:
    """Estimated positions, shape (M, 3), sorted by x then y, with the scene's workspace."""
    result = localize(session, workspace=WORKSPACE, **LOCALIZE_OPTIONS)
    pos = np.array([o.position for o in result.objects]).reshape(-1, 3)
    return pos[np.lexsort((pos[:, 1], pos[:, 0]))]


# ---------------------------------------------------------------------- ROS bags
#: Frames of the bag's TF tree: world -> base_link (static), base_link -> tool0 (on /tf),
#: tool0 -> camera_link (static), camera_link -> camera_optical_frame (static).
BAG_FRAMES = ("world", "base_link", "tool0", "camera_link", "camera_optical_frame")
#: Seconds after each keyframe at which the detector's image is stamped, and the keyframe spacing.
DETECTION_OFFSET = 0.03
KEYFRAME_STEP = 0.08

# vision_msgs as published (written out from the message files, independently of the library).
ROS1_VISION_MSGS = {
    "vision_msgs/msg/Detection2DArray": "Header header\nvision_msgs/Detection2D[] detections\n",
    "vision_msgs/msg/Detection2D": (
        "Header header\nvision_msgs/ObjectHypothesisWithPose[] results\nvision_msgs/BoundingBox2D bbox\nsensor_msgs/Image source_img\n"
    ),
    "vision_msgs/msg/ObjectHypothesisWithPose": "int64 id\nfloat64 score\ngeometry_msgs/PoseWithCovariance pose\n",
    "vision_msgs/msg/BoundingBox2D": "geometry_msgs/Pose2D center\nfloat64 size_x\nfloat64 size_y\n",
    "tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
}
ROS2_VISION_MSGS = {
    "vision_msgs/msg/Detection2DArray": "std_msgs/Header header\nDetection2D[] detections\n",
    "vision_msgs/msg/Detection2D": "std_msgs/Header header\nObjectHypothesisWithPose[] results\nBoundingBox2D bbox\nstring id\n",
    "vision_msgs/msg/ObjectHypothesisWithPose": "ObjectHypothesis hypothesis\ngeometry_msgs/PoseWithCovariance pose\n",
    "vision_msgs/msg/ObjectHypothesis": "string class_id\nfloat64 score\n",
    "vision_msgs/msg/BoundingBox2D": "vision_msgs/Pose2D center\nfloat64 size_x\nfloat64 size_y\n",
    "vision_msgs/msg/Pose2D": "vision_msgs/Point2D position\nfloat64 theta\n",
    "vision_msgs/msg/Point2D": "float64 x\nfloat64 y\n",
}


def T_world_base() -> np.ndarray:
    from monovisual3d.frames import transform_from_position_quaternion

    return transform_from_position_quaternion([0.3, -0.2, 0.75], [0.0, 0.0, 0.3826834323650898, 0.9238795325112867])


def T_tool0_cameralink() -> np.ndarray:
    from monovisual3d.frames import transform_from_position_quaternion

    return transform_from_position_quaternion([0.05, 0.0, 0.08], [0.0, 0.2588190451, 0.0, 0.9659258263])


def geodesic(Ta: np.ndarray, Tb: np.ndarray, s: float) -> np.ndarray:
    """Pose a fraction s of the way from Ta to Tb: linear position, constant-speed rotation (own formula)."""
    from scipy.spatial.transform import Rotation

    out = np.eye(4)
    delta = Rotation.from_matrix(Ta[:3, :3].T @ Tb[:3, :3]).as_rotvec()
    out[:3, :3] = Ta[:3, :3] @ Rotation.from_rotvec(s * delta).as_matrix()
    out[:3, 3] = (1 - s) * Ta[:3, 3] + s * Tb[:3, 3]
    return out


def bag_keyframes() -> list[tuple[float, np.ndarray]]:
    """``(t, T_base_tool0)`` samples published on /tf: two per view, the arm still moving between them."""
    from scipy.spatial.transform import Rotation

    from monovisual3d.frames import T_cameralink_optical, invert_transform

    X = invert_transform(T_cameralink_optical()) @ invert_transform(T_tool0_cameralink())  # T_optical_tool0
    out = []
    for i, T_opt in enumerate(camera_poses()):
        A = T_opt @ X
        B = A.copy()
        B[:3, :3] = A[:3, :3] @ Rotation.from_rotvec([0.02, -0.03, 0.05]).as_matrix()
        B[:3, 3] += [0.004, -0.003, 0.002]
        out += [(float(i), A), (i + KEYFRAME_STEP, B)]
    return out


def bag_true_poses() -> list[tuple[float, np.ndarray]]:
    """``(t, T_base_optical)`` of the camera when each image was taken (t = i + DETECTION_OFFSET)."""
    from monovisual3d.frames import T_cameralink_optical

    keys = bag_keyframes()
    out = []
    for i in range(len(keys) // 2):
        (ta, A), (tb, B) = keys[2 * i], keys[2 * i + 1]
        t = ta + DETECTION_OFFSET
        T_tool0 = geodesic(A, B, (t - ta) / (tb - ta))
        out.append((t, T_tool0 @ T_tool0_cameralink() @ T_cameralink_optical()))
    return out


def bag_reference_session_dict() -> dict[str, Any]:
    """The session the bag must import to: true poses at the detection stamps, boxes from them."""
    poses = [T for _, T in bag_true_poses()]
    data = direct_session_dict(CAMERA, poses)
    for v, (t, _) in zip(data["views"], bag_true_poses()):
        v["stamp"] = T0 + t
        del v["image"]
    return data


def make_message(store: Any, typename: str, **fields: Any) -> Any:
    """A message of ``typename`` with default values, overridden by ``fields``."""
    _, defs = store.fielddefs[typename]
    kwargs = {}
    for name, (kind, spec) in defs:
        if name in fields:
            kwargs[name] = fields[name]
        else:
            kwargs[name] = _default(store, kind, spec)
    return store.types[typename](**kwargs)


def _default(store: Any, kind: Any, spec: Any) -> Any:
    kind = int(kind)
    if kind == 1:  # BASE
        t = spec[0]
        return "" if t == "string" else (False if t == "bool" else 0)
    if kind == 2:  # NAME
        return make_message(store, spec)
    sub_kind, sub_spec = spec[0]
    n = spec[1] if kind == 3 else 0
    if int(sub_kind) == 1 and sub_spec[0] != "string":
        return np.zeros(n, dtype=np.dtype(sub_spec[0].replace("byte", "uint8").replace("char", "uint8").replace("bool", "bool")))
    return [_default(store, sub_kind, sub_spec) for _ in range(n)]


def write_scene_bag(path: Any, kind: str, *, drop_vision_definitions: bool = False) -> None:
    """Write the scene as a ROS bag: ``kind`` is ``ros1``, ``sqlite3`` or ``mcap``.

    Topics: /tf (base_link -> tool0 keyframes), /tf_static (three static transforms),
    /camera/camera_info, /detections (Detection2DArray: three tomatoes and a leaf per image,
    plus one message long after the last transform, which the importer must skip).
    """
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from monovisual3d.frames import T_cameralink_optical, position_quaternion_from_transform

    ros1 = kind == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    types: dict[str, Any] = {}
    for name, text in (ROS1_VISION_MSGS if ros1 else ROS2_VISION_MSGS).items():
        types.update(get_types_from_msg(text, name))
    store.register({k: v for k, v in types.items() if k not in store.fielddefs})
    M = lambda name, **kw: make_message(store, name, **kw)  # noqa: E731
    t0_ns = int(T0 * 1e9)

    def stamp(t: float) -> Any:
        ns = t0_ns + int(round(t * 1e9))
        return M("builtin_interfaces/msg/Time", sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def header(t: float, frame: str) -> Any:
        return M("std_msgs/msg/Header", stamp=stamp(t), frame_id=frame)

    def tf(t: float, parent: str, child: str, T: np.ndarray) -> Any:
        p, q = position_quaternion_from_transform(T)
        tr = M(
            "geometry_msgs/msg/Transform",
            translation=M("geometry_msgs/msg/Vector3", x=p[0], y=p[1], z=p[2]),
            rotation=M("geometry_msgs/msg/Quaternion", x=q[0], y=q[1], z=q[2], w=q[3]),
        )
        return M("geometry_msgs/msg/TransformStamped", header=header(t, parent), child_frame_id=child, transform=tr)

    def detection(t: float, box: np.ndarray, score: float, label: str) -> Any:
        cx, cy = 0.5 * (box[0] + box[2]), 0.5 * (box[1] + box[3])
        w, h = box[2] - box[0], box[3] - box[1]
        if ros1:
            centre = M("geometry_msgs/msg/Pose2D", x=cx, y=cy, theta=0.0)
            hyp = M("vision_msgs/msg/ObjectHypothesisWithPose", id={"tomato": 0, "leaf": 1}[label], score=score)
        else:
            centre = M("vision_msgs/msg/Pose2D", position=M("vision_msgs/msg/Point2D", x=cx, y=cy), theta=0.0)
            hyp = M(
                "vision_msgs/msg/ObjectHypothesisWithPose",
                hypothesis=M("vision_msgs/msg/ObjectHypothesis", class_id=label, score=score),
            )
        bbox = M("vision_msgs/msg/BoundingBox2D", center=centre, size_x=w, size_y=h)
        return M("vision_msgs/msg/Detection2D", header=header(t, "camera_optical_frame"), results=[hyp], bbox=bbox)

    if ros1:
        from rosbags.rosbag1 import Writer

        writer = Writer(path)
        serialize = store.serialize_ros1
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3)
        serialize = store.serialize_cdr
    tfm, det, info = "tf2_msgs/msg/TFMessage", "vision_msgs/msg/Detection2DArray", "sensor_msgs/msg/CameraInfo"
    with writer:
        c_tf = writer.add_connection("/tf", tfm, typestore=store)
        c_static = writer.add_connection("/tf_static", tfm, typestore=store)
        c_info = writer.add_connection("/camera/camera_info", info, typestore=store)
        c_det = writer.add_connection("/detections", det, typestore=store)

        def write(conn: Any, t: float, msg: Any, typename: str) -> None:
            writer.write(conn, t0_ns + int(round(t * 1e9)), serialize(msg, typename))

        static = [
            tf(0.0, "world", "base_link", T_world_base()),
            tf(0.0, "tool0", "camera_link", T_tool0_cameralink()),
            tf(0.0, "camera_link", "camera_optical_frame", T_cameralink_optical()),
        ]
        write(c_static, 0.0, M(tfm, transforms=static), tfm)
        # The arm's base frame publishes relative to world: base_link -> tool0 is what the robot driver sends.
        for t, T in bag_keyframes():
            write(c_tf, t, M(tfm, transforms=[tf(t, "base_link", "tool0", T)]), tfm)
        K = K_OPENCV.ravel()
        info_fields = {
            "K" if ros1 else "k": K,
            "D" if ros1 else "d": np.array(D_PLUMB_BOB),
            "R" if ros1 else "r": np.eye(3).ravel(),
        }
        P = np.hstack([K_OPENCV, np.zeros((3, 1))]).ravel()
        info_fields["P" if ros1 else "p"] = P
        for t in (0.0, 1.5, 3.0):
            msg = M(
                info, header=header(t, "camera_optical_frame"), width=640, height=480, distortion_model="plumb_bob", **info_fields
            )
            write(c_info, t, msg, info)
        leaf_box = np.array([40.0, 300.0, 90.0, 340.0])
        for t, T in bag_true_poses():
            dets = [detection(t, b, s, lab) for b, s, lab in zip(view_boxes(CAMERA, T), scores(), LABELS)]
            dets.append(detection(t, leaf_box, 0.95, "leaf"))
            write(c_det, t + 0.01, M(det, header=header(t, "camera_optical_frame"), detections=dets), det)
        # an image taken long after the last transform: no pose, must be skipped (and reported)
        late = bag_true_poses()[-1][0] + 5.0
        T_late = bag_true_poses()[-1][1]
        dets = [detection(late, b, s, lab) for b, s, lab in zip(view_boxes(CAMERA, T_late), scores(), LABELS)]
        write(c_det, late, M(det, header=header(late, "camera_optical_frame"), detections=dets), det)
    if drop_vision_definitions:
        import sqlite3

        db = next(iter(path.glob("*.db3")))
        with sqlite3.connect(db) as con:
            con.execute("DELETE FROM message_definitions WHERE topic_type LIKE 'vision_msgs/%'")


# ---------------------------------------------------------------------- files in the real formats
def write_camera_info_yaml(path: Any) -> None:
    """The scene camera as ROS camera_calibration YAML (OpenCV convention)."""
    K = ", ".join(repr(float(v)) for v in K_OPENCV.ravel())
    D = ", ".join(repr(v) for v in D_PLUMB_BOB)
    path.write_text(
        "image_width: 640\nimage_height: 480\ncamera_name: scene\n"
        f"camera_matrix:\n  rows: 3\n  cols: 3\n  data: [{K}]\n"
        "distortion_model: plumb_bob\n"
        f"distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [{D}]\n"
    )


def quaternion_xyzw(T: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(T[:3, :3]).as_quat()


def write_pose_csv(path: Any, poses: list[np.ndarray], *, images: bool = True, units: float = 1.0, rotvec: bool = False) -> None:
    """Poses as CSV: image, stamp, x, y, z and quaternion (or UR-style rotation vector); positions / units."""
    from scipy.spatial.transform import Rotation

    head = ["image"] * images + ["stamp", "x", "y", "z"] + (["rx", "ry", "rz"] if rotvec else ["qx", "qy", "qz", "qw"])
    rows = [",".join(head)]
    for i, T in enumerate(poses):
        rot = Rotation.from_matrix(T[:3, :3]).as_rotvec() if rotvec else quaternion_xyzw(T)
        cells = [f"img_{i:03d}.png"] * images + [repr(T0 + i)] + [repr(float(v / units)) for v in T[:3, 3]]
        rows.append(",".join(cells + [repr(float(v)) for v in rot]))
    path.write_text("\n".join(rows) + "\n")


def write_tum(path: Any, poses: list[np.ndarray], stamps: list[float]) -> None:
    lines = ["# timestamp tx ty tz qx qy qz qw"]
    for t, T in zip(stamps, poses):
        lines.append(" ".join(repr(float(v)) for v in [t, *T[:3, 3], *quaternion_xyzw(T)]))
    path.write_text("\n".join(lines) + "\n")


def write_yolo_labels(folder: Any, poses: list[np.ndarray], names: list[str] | None = None, camera: Camera = CAMERA) -> None:
    """One label file per view (``class cx cy w h conf``, normalised) and classes.txt."""
    folder.mkdir(parents=True, exist_ok=True)
    W, H = camera.size
    for i, T in enumerate(poses):
        lines = []
        for b, s in zip(view_boxes(camera, T), scores()):
            cx, cy, w, h = (b[0] + b[2]) / 2 / W, (b[1] + b[3]) / 2 / H, (b[2] - b[0]) / W, (b[3] - b[1]) / H
            lines.append(" ".join(["0"] + [repr(float(v)) for v in (cx, cy, w, h, s)]))
        name = names[i] if names is not None else f"img_{i:03d}"
        (folder / f"{name}.txt").write_text("\n".join(lines) + "\n")
    (folder / "classes.txt").write_text("tomato\nleaf\n")
