"""Library results -> the node's ROS 2 messages: Detection3DArray, MarkerArray, status String, PoseStamped.

Per fruit, ``vision_msgs/Detection3D``:

- ``bbox.center``: the centre and the orientation of the fitted shape (``quaternion_xyzw``; identity for a
  sphere); ``bbox.size``: the full extents, 2 x the semi-axes along the bbox's own axes;
- ``results[0].hypothesis``: ``class_id`` the label most of its boxes carry (empty without labels), ``score``
  the mean detector score of those boxes (1.0 when the boxes have none): a confidence in [0, 1], as ROS
  consumers expect; the method's own score (nats) is in the status message;
- ``results[0].pose.pose``: the centre; ``results[0].pose.covariance``: 6 x 6, row-major, the 3 x 3 position
  covariance in its upper-left block (m^2, base frame), the orientation block :data:`UNKNOWN_VARIANCE` on its
  diagonal (the orientation's uncertainty is not estimated);
- ``id``: the track id (:mod:`.tracks`), as text.

The markers for RViz: each fruit's fitted shape (namespace ``fruit``), its 95 % position-uncertainty
ellipsoid (``fruit_uncertainty``) and a label ``#id label`` (``fruit_label``), after a DELETEALL so that
fruit gone from the estimate disappear.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..frames import position_quaternion_from_transform
from ..io.ros_messages import NS_PER_S
from ..result import DetectedObject
from ..session import View
from . import msgs

#: Variance given to each orientation term of the covariance (rad^2): not estimated, so "anything" (a large value
#: rather than zero, which consumers read as exact).
UNKNOWN_VARIANCE = 1e6
#: chi-square quantile of 0.95 with 3 degrees of freedom: the 95 % ellipsoid of a 3D Gaussian has semi-axes
#: sqrt(this x eigenvalue) (``scipy.stats.chi2.ppf(0.95, 3)``).
CHI2_95_3D = 7.814727903251178
#: Size drawn for an object without a size (metres, radius).
FALLBACK_RADIUS_M = 0.03
#: Height of the label text above the fruit's centre, and of its letters, metres.
LABEL_OFFSET_M, LABEL_SIZE_M = 0.06, 0.025
#: Colours (r, g, b, a) of the markers.
FRUIT_RGBA = (0.9, 0.25, 0.1, 0.85)
UNCERTAINTY_RGBA = (0.2, 0.5, 1.0, 0.3)
LABEL_RGBA = (1.0, 1.0, 1.0, 1.0)


def time_msg(stamp_ns: int) -> msgs.Time:
    """``builtin_interfaces/Time`` of a stamp in nanoseconds."""
    sec, nanosec = divmod(int(stamp_ns), NS_PER_S)
    return msgs.Time(sec=sec, nanosec=nanosec)


def header(frame_id: str, stamp_ns: int) -> msgs.Header:
    return msgs.Header(stamp=time_msg(stamp_ns), frame_id=frame_id)


def pose_msg(position: ArrayLike, quaternion_xyzw: ArrayLike | None = None) -> msgs.Pose:
    x, y, z = (float(v) for v in np.asarray(position, dtype=float))
    qx, qy, qz, qw = (float(v) for v in (quaternion_xyzw if quaternion_xyzw is not None else (0.0, 0.0, 0.0, 1.0)))
    return msgs.Pose(position=msgs.Point(x=x, y=y, z=z), orientation=msgs.Quaternion(x=qx, y=qy, z=qz, w=qw))


def pose_stamped(T_frame_pose: ArrayLike, frame_id: str, stamp_ns: int) -> msgs.PoseStamped:
    """``geometry_msgs/PoseStamped`` of a 4x4 pose expressed in ``frame_id``."""
    p, q = position_quaternion_from_transform(np.asarray(T_frame_pose, dtype=float))
    return msgs.PoseStamped(header=header(frame_id, stamp_ns), pose=pose_msg(p, q))


def object_labels(objects: Sequence[DetectedObject], views: Sequence[View]) -> list[tuple[str, float]]:
    """Per object, the label most of its associated boxes carry ("" if none) and their mean detector score (1.0 if none)."""
    out = []
    for o in objects:
        dets = [views[v].detections[d] for v, d in o.associations.items() if v < len(views) and d < len(views[v].detections)]
        labels = Counter(d.label for d in dets if d.label)
        scores = [d.score for d in dets if d.score is not None]
        out.append((labels.most_common(1)[0][0] if labels else "", float(np.mean(scores)) if scores else 1.0))
    return out


def _extents(o: DetectedObject) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Full extents (3,) along the object's axes, metres, and its quaternion_xyzw (4,)."""
    q = np.asarray(o.quaternion_xyzw if o.quaternion_xyzw is not None else (0.0, 0.0, 0.0, 1.0), dtype=float)
    if o.semi_axes is not None:
        return 2.0 * np.asarray(o.semi_axes, dtype=float), q
    return np.full(3, 2.0 * (o.radius if o.radius is not None else FALLBACK_RADIUS_M)), q


def pose_covariance(covariance: ArrayLike | None) -> list[float]:
    """The 36 numbers of a ``PoseWithCovariance`` covariance: position block from ``covariance`` (3x3, m^2; zeros if
    None, which ROS reads as unknown), orientation block :data:`UNKNOWN_VARIANCE` on its diagonal."""
    C = np.zeros((6, 6))
    if covariance is not None:
        C[:3, :3] = np.asarray(covariance, dtype=float)
    C[3:, 3:] = np.eye(3) * UNKNOWN_VARIANCE
    return [float(v) for v in C.ravel()]


def detection3d_array(
    objects: Sequence[DetectedObject], ids: Sequence[int], labels: Sequence[tuple[str, float]], frame_id: str, stamp_ns: int
) -> msgs.Detection3DArray:
    """One ``vision_msgs/Detection3D`` per object, in ``frame_id`` (the base frame), stamped ``stamp_ns``."""
    hdr = header(frame_id, stamp_ns)
    out = []
    for o, track, (label, score) in zip(objects, ids, labels, strict=True):
        size, q = _extents(o)
        centre = pose_msg(o.position, q)
        result = msgs.ObjectHypothesisWithPose(
            hypothesis=msgs.ObjectHypothesis(class_id=label, score=score),
            pose=msgs.PoseWithCovariance(pose=pose_msg(o.position), covariance=pose_covariance(o.covariance)),
        )
        bbox = msgs.BoundingBox3D(center=centre, size=msgs.Vector3(x=float(size[0]), y=float(size[1]), z=float(size[2])))
        out.append(msgs.Detection3D(header=hdr, results=[result], bbox=bbox, id=str(int(track))))
    return msgs.Detection3DArray(header=hdr, detections=out)


def _marker(hdr: msgs.Header, ns: str, marker_id: int, kind: int, rgba: tuple[float, ...], **fields: Any) -> msgs.Marker:
    r, g, b, a = rgba
    return msgs.Marker(
        header=hdr, ns=ns, id=marker_id, type=kind, action=msgs.MARKER_ADD, color=msgs.ColorRGBA(r, g, b, a), **fields
    )


def uncertainty_ellipsoid(covariance: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Full extents (3,) of the 95 % ellipsoid of a 3x3 position covariance, metres, and its quaternion_xyzw (4,)."""
    w, V = np.linalg.eigh(np.asarray(covariance, dtype=float))
    if np.linalg.det(V) < 0:
        V[:, 2] *= -1.0
    T = np.eye(4)
    T[:3, :3] = V
    _, q = position_quaternion_from_transform(T)
    return 2.0 * np.sqrt(CHI2_95_3D * np.clip(w, 0.0, None)), q


def marker_array(
    objects: Sequence[DetectedObject], ids: Sequence[int], labels: Sequence[tuple[str, float]], frame_id: str, stamp_ns: int
) -> msgs.MarkerArray:
    """Markers for RViz: DELETEALL, then each fruit's shape, 95 % uncertainty ellipsoid and label (ids = track ids)."""
    hdr = header(frame_id, stamp_ns)
    markers = [msgs.Marker(header=hdr, action=msgs.MARKER_DELETEALL)]
    for o, track, (label, _) in zip(objects, ids, labels, strict=True):
        size, q = _extents(o)
        markers.append(
            _marker(hdr, "fruit", int(track), msgs.MARKER_SPHERE, FRUIT_RGBA, pose=pose_msg(o.position, q), scale=_vec(size))
        )
        if o.covariance is not None:
            extent, qc = uncertainty_ellipsoid(o.covariance)
            markers.append(
                _marker(
                    hdr,
                    "fruit_uncertainty",
                    int(track),
                    msgs.MARKER_SPHERE,
                    UNCERTAINTY_RGBA,
                    pose=pose_msg(o.position, qc),
                    scale=_vec(extent),
                )
            )
        above = np.asarray(o.position, dtype=float) + [0.0, 0.0, LABEL_OFFSET_M]
        text = f"#{int(track)} {label}".strip()
        markers.append(
            _marker(
                hdr,
                "fruit_label",
                int(track),
                msgs.MARKER_TEXT_VIEW_FACING,
                LABEL_RGBA,
                pose=pose_msg(above),
                scale=_vec([0.0, 0.0, LABEL_SIZE_M]),
                text=text,
            )
        )
    return msgs.MarkerArray(markers=markers)


def _vec(v: ArrayLike) -> msgs.Vector3:
    x, y, z = (float(c) for c in np.asarray(v, dtype=float))
    return msgs.Vector3(x=x, y=y, z=z)


def status_message(status: dict[str, Any]) -> msgs.String:
    """``std_msgs/String`` with the status as JSON (non-finite numbers as null)."""

    def clean(v: Any) -> Any:
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {str(k): clean(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [clean(x) for x in v]
        return v

    return msgs.String(data=json.dumps(clean(status), allow_nan=False))


__all__ = [
    "CHI2_95_3D",
    "UNKNOWN_VARIANCE",
    "detection3d_array",
    "header",
    "marker_array",
    "object_labels",
    "pose_covariance",
    "pose_stamped",
    "status_message",
    "time_msg",
    "uncertainty_ellipsoid",
]
