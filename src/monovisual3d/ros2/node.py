"""The ROS 2 node over DDS (extra ``[ros2]``): ``monovisual3d ros2 node``.

Two threads, so that estimation never runs on a DDS thread and no view is lost while it runs:

- the *receiver* waits on a DDS wait set and takes every sample as it comes: TF into the transform buffer,
  CameraInfo into the latest camera, each Detection2DArray (a view) and each reset into a FIFO inbox;
- the *estimator* takes the inbox in order: it resolves a view's camera and pose (waiting up to
  ``tf_timeout_s`` from the view's arrival for late TF), adds it to the session, adds every further view whose
  pose is already there (views that arrived during the last estimate), estimates from all views so far and
  publishes the Detection3DArray, the markers, the status and the next view. A view whose pose cannot be had is
  dropped and said so on the status topic.

Python's GIL is shared by the two threads, but the compiled kernels release it and Cyclone's own threads keep
receiving into the readers' histories (:data:`~monovisual3d.ros2.dds.INPUT_HISTORY` samples) meanwhile.
"""

from __future__ import annotations

import signal
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._extras import require
from ..errors import InputError
from ..frames import T_cameralink_optical
from ..io.calibration_ros import camera_from_camera_info
from ..io.detections import ImageDetections, filter_detections
from ..io.ros_messages import NS_PER_S, detections_from_array, stamp_ns
from ..io.tf import TransformUnavailable
from ..methods.bayes import BayesConfig
from . import dds, msgs
from .config import NodeConfig
from .live import LatestCamera, LiveSession, Outputs, PendingView, ViewDropped, resolve_view, view_frame, warm_up
from .outputs import detection3d_array, marker_array, status_message
from .tf_buffer import LiveTransforms

_core = require("cyclonedds.core", "ros2")
_util = require("cyclonedds.util", "ros2")
_internal = require("cyclonedds.internal", "ros2")

#: How often the threads look at the stop flag, seconds.
POLL_S = 0.1
#: Samples taken from one reader at a time.
TAKE_BATCH = 256
#: Seconds the node waits, when it stops, for its last status to be acknowledged by the reliable subscribers.
LINGER_S = 1.0
#: The inbox item that asks for a new session.
RESET = "reset"


class Inbox:
    """A FIFO of views and resets between the receiver and the estimator."""

    def __init__(self) -> None:
        self._items: deque[Any] = deque()
        self._cond = threading.Condition()

    def put(self, item: Any) -> None:
        with self._cond:
            self._items.append(item)
            self._cond.notify()

    def get(self, timeout_s: float) -> Any:
        """The first item, waiting up to ``timeout_s``; None if there is none."""
        with self._cond:
            if not self._cond.wait_for(lambda: bool(self._items), timeout=timeout_s):
                return None
            return self._items.popleft()

    def peek(self) -> Any:
        with self._cond:
            return self._items[0] if self._items else None

    def __len__(self) -> int:
        with self._cond:
            return len(self._items)


class FruitNode:
    """The node: subscriptions, publications and the two threads (see the module docstring).

    Parameters
    ----------
    config : NodeConfig
    method : BayesConfig, the method's options (default: the defaults of ``localize``)
    log : callable taking one line of text, or None (quiet)

    Examples
    --------
    >>> node = FruitNode(NodeConfig(warmup=False))  # doctest: +SKIP
    >>> node.start(); ...; node.stop()  # doctest: +SKIP
    """

    def __init__(self, config: NodeConfig, method: BayesConfig | None = None, log: Callable[[str], None] | None = None) -> None:
        self.config = config
        self.method = method or BayesConfig()
        self.log = log or (lambda line: None)
        self.transforms = LiveTransforms()
        self.cameras = LatestCamera()
        self.session = LiveSession(config, self.method)
        self.inbox = Inbox()
        self.domain_id = config.domain_id if config.domain_id is not None else dds.domain_id_from_env()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._last_frame = config.camera_frame or ""
        self._dp = dds.participant(self.domain_id)
        self._make_endpoints(dds.Endpoints(self._dp))

    def _make_endpoints(self, ep: Any) -> None:
        t, c = self.config.topics, self.config
        sensor = dds.sensor_reader_qos(c.reliable_inputs)
        self._readers: list[tuple[Any, Callable[[Any], None]]] = [
            (ep.reader(t.tf_static, msgs.TFMessage, dds.tf_static_reader_qos()), lambda m: self._on_tf(m, True)),
            (ep.reader(t.tf, msgs.TFMessage, dds.tf_reader_qos()), lambda m: self._on_tf(m, False)),
            (ep.reader(t.detections, msgs.Detection2DArray, sensor), self._on_detections),
            (ep.reader(t.reset, msgs.Empty, dds.tf_reader_qos()), lambda m: self.inbox.put(RESET)),
        ]
        if c.camera is None:
            self._readers.insert(2, (ep.reader(t.camera_info, msgs.CameraInfo, sensor), self._on_camera_info))
        else:
            self.cameras.set(c.camera)
        out = dds.output_writer_qos()
        self._writers = {
            "detections": ep.writer(t.out_detections, msgs.Detection3DArray, out),
            "markers": ep.writer(t.out_markers, msgs.MarkerArray, out),
            "status": ep.writer(t.out_status, msgs.String, out),
        }
        if c.candidates:
            self._writers["next_view"] = ep.writer(t.out_next_view, msgs.PoseStamped, out)

    # ------------------------------------------------------------------ receiver thread
    def _on_tf(self, msg: Any, static: bool) -> None:
        where = self.config.topics.tf_static if static else self.config.topics.tf
        for problem in self.transforms.add(msg, static, where):
            self.session.warn(problem)

    def _on_camera_info(self, msg: Any) -> None:
        try:
            self.cameras.set(camera_from_camera_info(msg))
        except InputError as exc:
            self.session.warn(f"{self.config.topics.camera_info}: {exc}")

    def _on_detections(self, msg: Any) -> None:
        dets, skipped = detections_from_array(msg)
        frame = ImageDetections(image=None, detections=tuple(dets))
        kept = filter_detections([frame], min_score=self.config.min_score, labels=self.config.labels)[0].detections
        if skipped:
            self.session.warn(f"{self.config.topics.detections}: {len(skipped)} box(es) left out ({skipped[0][1]})")
        self.session.received += 1
        self.inbox.put(PendingView(stamp_ns(msg.header.stamp), str(msg.header.frame_id), tuple(kept), time.monotonic()))

    def _receive(self) -> None:
        waitset = _core.WaitSet(self._dp)
        mask = _core.SampleState.Any | _core.ViewState.Any | _core.InstanceState.Any
        conditions = [_core.ReadCondition(reader, mask) for reader, _ in self._readers]
        for condition in conditions:
            waitset.attach(condition)
        while not self._stop.is_set():
            waitset.wait(_util.duration(seconds=POLL_S))
            for reader, handler in self._readers:
                self._take(reader, handler)

    def _take(self, reader: Any, handler: Callable[[Any], None]) -> None:
        try:
            samples = reader.take(N=TAKE_BATCH)
        except Exception as exc:  # bytes that do not decode: another message version on the topic
            self.session.warn(f"{reader.topic.name}: cannot decode a message ({type(exc).__name__}); another message version?")
            return
        for sample in samples:
            if not isinstance(sample, _internal.InvalidSample):
                handler(sample)

    # ------------------------------------------------------------------ estimator thread
    def _estimate_loop(self) -> None:
        while not self._stop.is_set():
            item = self.inbox.get(POLL_S)
            if item is None:
                continue
            if item == RESET:
                self._reset()
                continue
            added = self._add(item)
            while isinstance(self.inbox.peek(), PendingView) and self._ready_or_late(self.inbox.peek()):
                added = self._add(self.inbox.get(0.0)) or added
            if added:
                self._estimate()

    def _ready_or_late(self, pending: PendingView) -> bool:
        """The view can be resolved now, or its deadline has passed (it is dropped at once)."""
        if time.monotonic() > pending.arrived + self.config.tf_timeout_s:
            return True
        if self.config.camera is None and self.cameras.get(0.0) is None:
            return False
        frame = view_frame(pending, self.config)
        return bool(frame) and self.transforms.available(
            self.config.base_frame, frame, pending.stamp_ns / NS_PER_S, max_gap=self.config.max_gap_s
        )

    def _add(self, pending: PendingView) -> bool:
        try:
            view, camera = resolve_view(pending, self.transforms, self.cameras, self.config)
        except ViewDropped as exc:
            self._write("status", status_message(self.session.drop(pending, str(exc))))
            self.log(f"dropped the view at {pending.stamp_ns / NS_PER_S:.3f} s: {exc}")
            return False
        self._last_frame = view_frame(pending, self.config)
        return self.session.add(view, camera)

    def _estimate(self) -> None:
        out = self.session.estimate(self._T_tool_optical())
        if out is None:
            return
        self._publish(out)
        s = out.status
        self.log(f"views {s['views']} (+{s['views_in_estimate']}): {s['fruit']} fruit, estimate {s['estimate_s']:.2f} s")

    def _T_tool_optical(self) -> NDArray[np.float64] | None:
        """The camera's optical frame in the tool frame, from TF (the hand-eye transform); None without a tool frame."""
        tool = self.config.tool_frame
        if tool is None or not self.config.candidates or not self._last_frame:
            return None
        stamp = self.session.last_stamp_ns / NS_PER_S
        try:
            T = self.transforms.lookup(tool, self._last_frame, stamp, max_gap=self.config.max_gap_s, timeout_s=0.0)
        except TransformUnavailable as exc:
            self.session.warn(f"next view: no transform {tool} -> {self._last_frame}: {exc}")
            return None
        return T @ T_cameralink_optical() if self.config.pose_frame == "camera_link" else T

    def _publish(self, out: Outputs) -> None:
        self._write("detections", out.detections)
        self._write("markers", out.markers)
        if out.next_view is not None:
            self._write("next_view", out.next_view)
        self._write("status", status_message(out.status))

    def _reset(self) -> None:
        self.session.reset()
        stamp = int(time.time() * NS_PER_S)
        self._write("detections", detection3d_array([], [], [], self.config.base_frame, stamp))
        self._write("markers", marker_array([], [], [], self.config.base_frame, stamp))
        self._write("status", status_message(self.session.status("reset")))
        self.log("reset: a new session")

    def _write(self, name: str, message: Any) -> None:
        writer = self._writers.get(name)
        if writer is not None:
            writer.write(message)

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Warm up (unless ``config.warmup`` is off), start the threads and publish a ``started`` status."""
        if self.config.warmup:
            self.log(f"warm-up: {warm_up(self.method):.1f} s")
        self._threads = [
            threading.Thread(target=self._receive, name="mv3d-ros2-receive", daemon=True),
            threading.Thread(target=self._estimate_loop, name="mv3d-ros2-estimate", daemon=True),
        ]
        for thread in self._threads:
            thread.start()
        status = self.session.status("started")
        status["domain_id"] = self.domain_id
        status["topics"] = self.config.topics.to_dict()
        self._write("status", status_message(status))
        self.log(
            f"running on ROS domain {self.domain_id}: {self.config.topics.detections} -> {self.config.topics.out_detections}"
        )

    def stop(self) -> None:
        """Stop the threads (the estimate under way finishes first), publish a ``stopped`` status, leave the domain."""
        self._stop.set()
        for thread in self._threads:
            thread.join()
        if self._dp is None:
            return
        self._write("status", status_message(self.session.status("stopped")))
        self._writers["status"].wait_for_acks(_util.duration(seconds=LINGER_S))
        dp, self._dp, self._readers, self._writers = self._dp, None, [], {}
        dp.__del__()  # deletes the participant and its readers and writers now, not at garbage collection

    def spin(self, stop: threading.Event) -> None:
        """Run until ``stop`` is set."""
        self.start()
        try:
            while not stop.wait(POLL_S):  # a timed wait: signal handlers run between the waits
                pass
        finally:
            self.stop()


def run_until_signal(node: FruitNode) -> None:
    """Run ``node`` until SIGINT or SIGTERM (from the main thread), then stop it cleanly."""
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda signum, frame: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        node.spin(stop)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


__all__ = ["FruitNode", "Inbox", "run_until_signal"]
