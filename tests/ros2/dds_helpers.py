"""Helpers of the DDS tests: a running node, a collector of its outputs (the project's readers), a waiting loop."""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Callable, Iterator
from typing import Any

from monovisual3d.methods.bayes import BayesConfig
from monovisual3d.ros2 import dds, msgs
from monovisual3d.ros2.config import NodeConfig, Topics
from monovisual3d.ros2.node import FruitNode

#: Seconds a test waits for the node's answer before it fails (generous: the CI machine is shared and slow).
ANSWER_S = 60.0


def topics(name: str) -> Topics:
    """Topics of one test, all remapped under ``/NAME`` so that tests never hear each other."""
    base = f"/{name}"
    return Topics.with_prefix(
        f"{base}/fruit",
        camera_info=f"{base}/camera_info",
        detections=f"{base}/detections",
        tf=f"{base}/tf",
        tf_static=f"{base}/tf_static",
    )


@contextlib.contextmanager
def running_node(config: NodeConfig, method: BayesConfig | None = None) -> Iterator[FruitNode]:
    node = FruitNode(config, method)
    node.start()
    try:
        yield node
    finally:
        node.stop()


class Collector:
    """The node's status (parsed JSON) and Detection3DArray messages, as a subscriber on its own participant sees them."""

    def __init__(self, t: Topics) -> None:
        self._dp = dds.participant(dds.domain_id_from_env())
        ep = dds.Endpoints(self._dp)
        self._status = ep.reader(t.out_status, msgs.String, dds.tf_static_reader_qos())
        self._detections = ep.reader(t.out_detections, msgs.Detection3DArray, dds.tf_static_reader_qos())
        self._next_view = ep.reader(t.out_next_view, msgs.PoseStamped, dds.tf_static_reader_qos())
        self.reset_writer = ep.writer(t.reset, msgs.Empty, dds.publisher_qos("default"))
        self.statuses: list[dict[str, Any]] = []
        self.detections: list[Any] = []
        self.next_views: list[Any] = []

    def poll(self) -> None:
        self.statuses += [json.loads(s.data) for s in self._status.take(256)]
        self.detections += list(self._detections.take(256))
        self.next_views += list(self._next_view.take(256))

    def wait_for(self, condition: Callable[[Collector], bool], timeout_s: float = ANSWER_S) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.poll()
            if condition(self):
                return True
            time.sleep(0.05)
        return False

    def last(self, event: str) -> dict[str, Any] | None:
        return next((s for s in reversed(self.statuses) if s["event"] == event), None)

    def close(self) -> None:
        self._dp.__del__()
