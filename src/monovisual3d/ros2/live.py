"""One live session of the node, free of DDS: views in, estimates and their messages out.

- :class:`PendingView`: a Detection2DArray as it arrived (boxes, stamp, frame, arrival time);
- :func:`resolve_view`: its camera (the latest CameraInfo, or the given calibration) and its pose
  ``T_base_optical`` from TF at its stamp, waiting for late TF up to the view's deadline; else :class:`ViewDropped`;
- :class:`LiveSession`: the ``bayes`` :class:`~monovisual3d.methods.bayes.BayesLocalizer` of the session, the
  track ids, the counts of views received, used and dropped; :meth:`LiveSession.estimate` runs the method on all
  views so far and returns the messages to publish.

The node (:mod:`.node`) feeds it from its DDS threads; the tests feed it directly.
"""

from __future__ import annotations

import threading
import time
import warnings
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from ..frames import T_base_optical_from_T_base_cameralink, T_cameralink_optical
from ..io.ros_messages import NS_PER_S
from ..io.tf import TransformUnavailable
from ..methods.bayes import BayesConfig, BayesLocalizer
from ..methods.bayes.localizer import warm_up as bayes_warm_up
from ..session import Detection, View
from . import msgs
from .config import NodeConfig
from .next_view import NextView, NextViewPlanner
from .outputs import detection3d_array, marker_array, object_labels, pose_stamped
from .tf_buffer import LiveTransforms
from .tracks import TrackTable

#: Dropped views and node warnings kept for the status message.
RECENT = 10


@dataclass(frozen=True)
class PendingView:
    """A Detection2DArray as it arrived.

    Attributes
    ----------
    stamp_ns : int, the header stamp, nanoseconds
    frame_id : str, the header frame (the camera's TF frame unless the node is given one)
    detections : tuple of Detection, boxes in pixels (after the score and label filters)
    arrived : float, ``time.monotonic()`` at arrival: the TF wait runs from here
    """

    stamp_ns: int
    frame_id: str
    detections: tuple[Detection, ...]
    arrived: float


class ViewDropped(Exception):
    """A view whose camera or pose could not be had (the message says why)."""


class LatestCamera:
    """The camera of the latest CameraInfo, shared between the DDS thread (:meth:`set`) and the estimator."""

    def __init__(self) -> None:
        self._camera: Camera | None = None
        self._changed = threading.Condition()

    def set(self, camera: Camera) -> None:
        with self._changed:
            self._camera = camera
            self._changed.notify_all()

    def get(self, timeout_s: float) -> Camera | None:
        """The latest camera, waiting up to ``timeout_s`` for the first one."""
        with self._changed:
            self._changed.wait_for(lambda: self._camera is not None, timeout=max(timeout_s, 0.0))
            return self._camera


def view_frame(pending: PendingView, config: NodeConfig) -> str:
    """The TF frame of the view's camera: the configured one, else the detections' header frame."""
    return config.camera_frame or pending.frame_id


def resolve_view(
    pending: PendingView, transforms: LiveTransforms, cameras: LatestCamera, config: NodeConfig, now: float | None = None
) -> tuple[View, Camera]:
    """The view's ``View`` (pose ``T_base_optical`` at its stamp) and camera, waiting until its deadline.

    The deadline is ``pending.arrived + config.tf_timeout_s``; past it nothing is waited for.

    Raises
    ------
    ViewDropped
        No camera frame, no CameraInfo, or no transform by the deadline (the reason says which).
    """
    frame = view_frame(pending, config)
    if not frame:
        raise ViewDropped("the Detection2DArray has no header.frame_id: give the camera frame (--camera-frame)")
    left = pending.arrived + config.tf_timeout_s - (time.monotonic() if now is None else now)
    camera = config.camera or cameras.get(left)
    if camera is None:
        raise ViewDropped(f"no CameraInfo on {config.topics.camera_info} within {config.tf_timeout_s:g} s")
    stamp = pending.stamp_ns / NS_PER_S
    left = pending.arrived + config.tf_timeout_s - time.monotonic()
    try:
        T = transforms.lookup(config.base_frame, frame, stamp, max_gap=config.max_gap_s, timeout_s=left)
    except TransformUnavailable as exc:
        raise ViewDropped(
            f"no transform {config.base_frame} -> {frame} at {stamp:.3f} s within {config.tf_timeout_s:g} s: {exc}"
        ) from None
    if config.pose_frame == "camera_link":
        T = T_base_optical_from_T_base_cameralink(T)
    return View(T, pending.detections, stamp=stamp), camera


def warm_up(method: BayesConfig) -> float:
    """One estimate of the built-in example session with ``method``, so the compiled kernels are ready; seconds taken."""
    return bayes_warm_up(method)


@dataclass
class Outputs:
    """What one estimate publishes: the messages, and the status (a JSON-ready dict)."""

    detections: msgs.Detection3DArray
    markers: msgs.MarkerArray
    status: dict[str, Any]
    next_view: msgs.PoseStamped | None = None


class LiveSession:
    """The node's state between two resets (see the module docstring).

    Parameters
    ----------
    config : NodeConfig
    method : BayesConfig, the method's options
    """

    def __init__(self, config: NodeConfig, method: BayesConfig) -> None:
        self.config = config
        self.method = method
        self.planner = NextViewPlanner(config.candidates, config.target_mm, config.workspace) if config.candidates else None
        self.received = 0
        self.dropped_count = 0
        self.sessions = 0
        self.warnings: deque[str] = deque(maxlen=RECENT)
        self._warnings_lock = threading.Lock()  # the receiver thread warns while the estimator reports
        self.dropped: deque[dict[str, Any]] = deque(maxlen=RECENT)
        self.reset()

    def reset(self) -> None:
        """Start a new session: no views, no fruit, track ids from 0 again (the counters of received views stay)."""
        self.localizer: BayesLocalizer | None = None
        self.tracks = TrackTable()
        self.pending_in_estimate = 0
        self.last_stamp_ns = 0
        self.objects: list[Any] = []
        self.sessions += 1

    def warn(self, message: str) -> None:
        """A node warning for the next status message (from any thread)."""
        with self._warnings_lock:
            self.warnings.append(message)

    def drop(self, pending: PendingView, reason: str) -> dict[str, Any]:
        """Record a dropped view; the status to publish."""
        self.dropped_count += 1
        self.dropped.append({"stamp": pending.stamp_ns / NS_PER_S, "reason": reason})
        self.warn(f"view at {pending.stamp_ns / NS_PER_S:.3f} s dropped: {reason}")
        return self.status("dropped")

    def add(self, view: View, camera: Camera) -> bool:
        """Add a resolved view; False (and a warning) when its camera differs from the session's."""
        if self.localizer is None:
            self.localizer = BayesLocalizer(camera, self.method, workspace=self.config.workspace)
        elif camera != self.localizer.camera:
            reason = (
                "its CameraInfo differs from the session's first one; publish on the reset topic to start a new session with it"
            )
            self.drop(PendingView(int(round((view.stamp or 0.0) * NS_PER_S)), "", view.detections, 0.0), reason)
            return False
        self.localizer.update(view)
        self.pending_in_estimate += 1
        self.last_stamp_ns = max(self.last_stamp_ns, int(round((view.stamp or 0.0) * NS_PER_S)))
        return True

    def estimate(self, T_tool_optical: NDArray[np.float64] | None = None) -> Outputs | None:
        """Estimate from all views so far; the messages to publish (None before the first view)."""
        loc = self.localizer
        if loc is None:
            return None
        t0, c0 = time.perf_counter(), time.process_time()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                objects = loc.estimate()
            except Exception as exc:  # the node keeps running; the status says what went wrong
                objects = []
                self.warn(f"estimate failed: {type(exc).__name__}: {exc}")
        estimate_s, estimate_cpu_s = time.perf_counter() - t0, time.process_time() - c0
        self.objects = objects
        raised = [str(w.message) for w in caught] + list(getattr(loc.last, "warnings", None) or [])
        method_warnings = list(dict.fromkeys(raised))  # the localizer raises what it keeps in last.warnings: once each
        ids = self.tracks.update(np.array([o.position for o in objects]).reshape(-1, 3))
        labels = object_labels(objects, loc.views)
        frame = self.config.base_frame
        out = Outputs(
            detection3d_array(objects, ids, labels, frame, self.last_stamp_ns),
            marker_array(objects, ids, labels, frame, self.last_stamp_ns),
            {},
        )
        plan = self._plan(objects, T_tool_optical)
        if plan is not None:
            out.next_view = self._next_view_msg(plan)
        out.status = self.status(
            "estimate",
            estimate_s=estimate_s,
            estimate_cpu_s=estimate_cpu_s,
            method_warnings=method_warnings,
            ids=ids,
            labels=labels,
            plan=plan,
        )
        self.pending_in_estimate = 0
        return out

    def _plan(self, objects: list[Any], T_tool_optical: NDArray[np.float64] | None) -> NextView | None:
        if self.planner is None or self.localizer is None:
            return None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return self.planner.plan(self.localizer, objects, T_tool_optical)
        except Exception as exc:  # a plan that fails must not stop the estimates
            self.warn(f"next view failed: {type(exc).__name__}: {exc}")
            return None

    def _next_view_msg(self, plan: NextView) -> msgs.PoseStamped:
        """The goal pose of the tool frame, else of the camera frame (in its convention), in the base frame."""
        T = plan.T_base_tool if plan.T_base_tool is not None else plan.T_base_camera
        if plan.T_base_tool is None and self.config.pose_frame == "camera_link":
            T = T @ np.linalg.inv(T_cameralink_optical())
        return pose_stamped(T, self.config.base_frame, self.last_stamp_ns)

    def _take_warnings(self) -> list[str]:
        """The node warnings since the last status, each reported once."""
        with self._warnings_lock:
            out = list(self.warnings)
            self.warnings.clear()
        return out

    def status(self, event: str, **extra: Any) -> dict[str, Any]:
        """The status as a JSON-ready dict (see docs/ros2.md); node warnings are reported once."""
        loc = self.localizer
        quality = getattr(loc.last, "quality", None) if loc is not None else None
        quality = quality if isinstance(quality, dict) else {}
        out: dict[str, Any] = {
            "event": event,
            "session": self.sessions,
            "stamp": self.last_stamp_ns / NS_PER_S if self.last_stamp_ns else None,
            "views": len(loc.views) if loc is not None else 0,
            "views_received": self.received,
            "views_dropped": self.dropped_count,
            "fruit": len(self.objects),
            "verdict": quality.get("verdict"),
            "causes": list(quality.get("causes", [])),
            "warnings": list(extra.get("method_warnings", [])) + self._take_warnings(),
            "dropped": list(self.dropped),
        }
        if event == "estimate":
            out["views_in_estimate"] = self.pending_in_estimate
            out["estimate_s"] = extra.get("estimate_s")
            out["estimate_cpu_s"] = extra.get("estimate_cpu_s")
            out["tracks"] = _tracks(self.objects, extra["ids"], extra["labels"])
            plan = extra.get("plan")
            if plan is not None:
                out["next_view"] = {"index": plan.index, "gain_mm": plan.gain, "done": plan.done}
        return out


def _tracks(objects: list[Any], ids: Any, labels: list[tuple[str, float]]) -> list[dict[str, Any]]:
    """Per fruit: id, position (m), the method's score (nats), label, box score, views."""
    return [
        {
            "id": int(i),
            "position": [float(x) for x in o.position],
            "method_score": float(o.score),
            "label": label,
            "box_score": score,
            "views": len(o.associations),
        }
        for o, i, (label, score) in zip(objects, ids, labels, strict=True)
    ]


__all__ = ["LatestCamera", "LiveSession", "Outputs", "PendingView", "ViewDropped", "resolve_view", "view_frame", "warm_up"]
