"""The node's options: its topics (:class:`Topics`) and everything else (:class:`NodeConfig`). No DDS import."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any

from ..camera import Camera
from ..errors import InputError
from ..io.build import DEFAULT_MAX_GAP
from ..session import Workspace
from ..session.load import POSE_FRAMES
from .names import absolute_topic, prefixed

#: Default prefix of the node's own topics (outputs and reset).
DEFAULT_PREFIX = "/fruit"
#: Names of the node's own topics under the prefix.
OWN_TOPICS = {
    "reset": "reset",
    "out_detections": "detections",
    "out_markers": "markers",
    "out_status": "status",
    "out_next_view": "next_view",
}


@dataclass(frozen=True)
class Topics:
    """The ROS 2 topics of the node (absolute names).

    Attributes
    ----------
    camera_info : str, sensor_msgs/CameraInfo in
    detections : str, vision_msgs/Detection2DArray in
    tf, tf_static : str, tf2_msgs/TFMessage in
    reset : str, std_msgs/Empty in: starts a new session
    out_detections : str, vision_msgs/Detection3DArray out
    out_markers : str, visualization_msgs/MarkerArray out
    out_status : str, std_msgs/String (JSON) out
    out_next_view : str, geometry_msgs/PoseStamped out (with candidates)
    """

    camera_info: str = "/camera/camera_info"
    detections: str = "/detections"
    tf: str = "/tf"
    tf_static: str = "/tf_static"
    reset: str = DEFAULT_PREFIX + "/reset"
    out_detections: str = DEFAULT_PREFIX + "/detections"
    out_markers: str = DEFAULT_PREFIX + "/markers"
    out_status: str = DEFAULT_PREFIX + "/status"
    out_next_view: str = DEFAULT_PREFIX + "/next_view"

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, absolute_topic(getattr(self, f.name), f.name))

    @classmethod
    def with_prefix(cls, prefix: str = DEFAULT_PREFIX, **remap: str | None) -> Topics:
        """The topics with the node's own (reset and outputs) under ``prefix``, then any of ``remap`` not None.

        Examples
        --------
        >>> Topics.with_prefix("/left/fruit", detections="/yolo/detections").out_status
        '/left/fruit/status'
        """
        own = {k: prefixed(prefix, v) for k, v in OWN_TOPICS.items()}
        unknown = sorted(set(remap) - {f.name for f in fields(cls)})
        if unknown:
            raise InputError(f"topics: unknown topic {unknown[0]!r}, expected one of {[f.name for f in fields(cls)]}")
        return cls(**{**own, **{k: v for k, v in remap.items() if v is not None}})

    def to_dict(self) -> dict[str, str]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class NodeConfig:
    """Everything the node does, besides the method's options.

    Attributes
    ----------
    topics : Topics
    base_frame : str, the frame of the outputs; camera poses are ``T_base_camera`` from TF
    camera_frame : str or None, the camera's TF frame (None: each Detection2DArray's ``header.frame_id``)
    pose_frame : str, convention of the camera frame: ``optical`` (REP 103 optical: z forward, x right, y down;
        the usual ``*_optical_frame``) or ``camera_link`` (x forward, y left, z up)
    tool_frame : str or None, the next view is published as this frame's goal pose (through the static TF
        from it to the camera, the hand-eye calibration); None: as the camera frame's pose
    tf_timeout_s : float, seconds a view waits for TF (and for the first CameraInfo) arriving after it
    max_gap_s : float, seconds: largest time between a view's stamp and the TF samples interpolated for it
    camera : Camera or None, intrinsics to use instead of the CameraInfo topic
    workspace : Workspace or None, the region searched (default: the method's cube in front of the first view)
    min_score : float or None, drop boxes scored below this
    labels : tuple of str or None, keep only boxes with these labels
    candidates : str or None, next-view candidates: a poses file or ``cap:N[...]`` (see ``monovisual3d next-view``)
    target_mm : float, the next-view stopping rule: largest 95 % semi-axis of every fruit, millimetres
    warmup : bool, run one estimate of the built-in example at start, so the first view does not pay the compile time
    reliable_inputs : bool, subscribe to detections and camera info reliably (default best effort: matches reliable
        and best-effort publishers alike; reliable matches only reliable ones)
    domain_id : int or None, DDS domain (None: ``ROS_DOMAIN_ID``, 0 when unset)
    """

    topics: Topics = field(default_factory=Topics)
    base_frame: str = "base_link"
    camera_frame: str | None = None
    pose_frame: str = "optical"
    tool_frame: str | None = None
    tf_timeout_s: float = 1.0
    max_gap_s: float = DEFAULT_MAX_GAP
    camera: Camera | None = None
    workspace: Workspace | None = None
    min_score: float | None = None
    labels: tuple[str, ...] | None = None
    candidates: str | None = None
    target_mm: float = 5.0
    warmup: bool = True
    reliable_inputs: bool = False
    domain_id: int | None = None

    def __post_init__(self) -> None:
        for name in ("base_frame", "camera_frame", "tool_frame"):
            value = getattr(self, name)
            if value is not None and not str(value).strip().lstrip("/"):
                raise InputError(f"{name}: got {value!r}, expected a TF frame name")
        if self.pose_frame not in POSE_FRAMES:
            raise InputError(f"pose_frame: got {self.pose_frame!r}, expected one of {list(POSE_FRAMES)}")
        for name in ("tf_timeout_s", "max_gap_s", "target_mm"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise InputError(f"{name}: got {value!r}, expected a number >= 0")
        if self.min_score is not None and not 0.0 <= self.min_score <= 1.0:
            raise InputError(f"min_score: got {self.min_score!r}, expected a value in [0, 1]")
        if self.domain_id is not None and not (type(self.domain_id) is int and 0 <= self.domain_id <= 232):
            raise InputError(f"domain_id: got {self.domain_id!r}, expected an integer from 0 to 232")

    def replace(self, **changes: Any) -> NodeConfig:
        return replace(self, **changes)


__all__ = ["DEFAULT_PREFIX", "NodeConfig", "Topics"]
