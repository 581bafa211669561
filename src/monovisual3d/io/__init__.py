"""Real-world inputs -> sessions: calibrations, detections, poses, ROS bags.

Readers by concept:

- :mod:`~monovisual3d.io.calibration`: Kalibr, ROS camera_info, OpenCV FileStorage, DepthAI -> :class:`~monovisual3d.Camera`
- :mod:`~monovisual3d.io.detections`: YOLO labels, COCO JSON, CSV -> :class:`ImageDetections`
- :mod:`~monovisual3d.io.yolo`: run an Ultralytics model (extra ``[yolo]``)
- :mod:`~monovisual3d.io.poses`: TUM, CSV, JSON poses, hand-eye calibration, interpolation
- :mod:`~monovisual3d.io.rosbag`: ROS 1/2 bags (extra ``[ros]``)
- :mod:`~monovisual3d.io.ros_messages`: ROS message fields -> stamps, transforms, detections (bags and the ROS 2 node)
- :mod:`~monovisual3d.io.build`: :func:`import_session` / :func:`build_session` -> validated session + summary
- :mod:`~monovisual3d.io.schema`: the session file's JSON Schema

Example::

    from monovisual3d.io import import_session
    result = import_session("calib.json", "poses.csv", "labels/", hand_eye="hand_eye.yaml")
    result.session.to_json("session.json")
    print("\\n".join(result.summary.lines()))
"""

from __future__ import annotations

from .build import DEFAULT_MAX_GAP, MATCH_MODES, assemble_session, build_session, import_session
from .calibration import CALIBRATION_FORMATS, calibration_format, read_calibration
from .calibration_depthai import camera_from_depthai
from .calibration_kalibr import camera_from_kalibr
from .calibration_opencv import camera_from_opencv_storage
from .calibration_ros import camera_from_camera_info
from .detections import (
    DETECTION_FORMATS,
    ImageDetections,
    filter_detections,
    load_class_names,
    read_coco,
    read_detections,
    read_detections_csv,
    read_yolo_labels,
)
from .image_size import camera_for_image_size, crop_camera
from .poses import (
    POSE_FORMATS,
    PoseTrajectory,
    T_base_camera_from_T_base_ee,
    T_base_ee_from_T_base_camera,
    interpolate_poses,
    read_hand_eye,
    read_pose_csv,
    read_pose_json,
    read_poses,
    read_tum,
)
from .rosbag import read_bag  # rosbags itself is imported when a bag is read
from .schema import session_schema, session_schema_path, validate_session_schema
from .summary import ImportResult, ImportSummary, Skipped
from .tf import TransformTree
from .yolo import detect_with_ultralytics, image_detections_from_result

__all__ = [
    "CALIBRATION_FORMATS",
    "DEFAULT_MAX_GAP",
    "DETECTION_FORMATS",
    "MATCH_MODES",
    "POSE_FORMATS",
    "ImageDetections",
    "ImportResult",
    "ImportSummary",
    "PoseTrajectory",
    "Skipped",
    "T_base_camera_from_T_base_ee",
    "T_base_ee_from_T_base_camera",
    "TransformTree",
    "assemble_session",
    "build_session",
    "calibration_format",
    "camera_for_image_size",
    "camera_from_camera_info",
    "camera_from_depthai",
    "camera_from_kalibr",
    "camera_from_opencv_storage",
    "crop_camera",
    "detect_with_ultralytics",
    "filter_detections",
    "image_detections_from_result",
    "import_session",
    "interpolate_poses",
    "load_class_names",
    "read_bag",
    "read_calibration",
    "read_coco",
    "read_detections",
    "read_detections_csv",
    "read_hand_eye",
    "read_pose_csv",
    "read_pose_json",
    "read_poses",
    "read_tum",
    "read_yolo_labels",
    "session_schema",
    "session_schema_path",
    "validate_session_schema",
]
