"""A live transform buffer: ``/tf`` and ``/tf_static`` as they arrive, looked up with a wait for late samples.

The transforms go into a :class:`~monovisual3d.io.tf.TransformTree` (the one the bag importer uses): each
lookup chains the edges from the base frame to the camera frame at the view's stamp, interpolating every
moving edge between its samples (linear in position, slerp in rotation). Live, samples after the stamp may
still be on their way: a lookup waits (up to a timeout) until every moving edge has a sample at or after the
stamp, rather than extrapolating from the last one, as tf2's ``lookupTransform`` with a timeout does.
Samples older than :data:`CACHE_S` before the newest are forgotten (tf2's default cache is 10 s).
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..io.ros_messages import NS_PER_S, transforms_from_tf_message
from ..io.tf import TransformTree, TransformUnavailable

#: Seconds of moving-transform samples kept before the newest one (tf2's default buffer length).
CACHE_S = 10.0
#: Forget old samples once the newest stamp has moved on by this many seconds since the last time.
PRUNE_EVERY_S = 1.0


class LiveTransforms:
    """Thread-safe transform buffer fed by TF messages, with waiting lookups.

    Examples
    --------
    >>> from types import SimpleNamespace as NS
    >>> def tf(parent, child, x, sec):
    ...     h = NS(frame_id=parent, stamp=NS(sec=sec, nanosec=0))
    ...     t = NS(translation=NS(x=x, y=0.0, z=0.0), rotation=NS(x=0.0, y=0.0, z=0.0, w=1.0))
    ...     return NS(transforms=[NS(header=h, child_frame_id=child, transform=t)])
    >>> buf = LiveTransforms()
    >>> buf.add(tf("base", "tool", 0.0, 10), static=False); buf.add(tf("base", "tool", 1.0, 11), static=False)
    []
    []
    >>> float(buf.lookup("base", "tool", 10.5, max_gap=1.0, timeout_s=0.0)[0, 3])
    0.5
    """

    def __init__(self) -> None:
        self._tree = TransformTree()
        self._changed = threading.Condition()
        self._newest = -np.inf
        self._pruned_at = -np.inf

    def add(self, msg: Any, static: bool, where: str = "tf") -> list[str]:
        """Add a ``tf2_msgs/TFMessage``; the problems of the transforms left out, one line each."""
        problems: list[str] = []
        with self._changed:
            try:
                items = list(transforms_from_tf_message(msg, where))
            except InputError as exc:
                return [str(exc)]
            for parent, child, T, ns in items:
                stamp = None if static else ns / NS_PER_S
                try:
                    self._tree.add(parent, child, T, stamp=stamp)
                except InputError as exc:
                    problems.append(f"{where}: {exc}")
                    continue
                if stamp is not None:
                    self._newest = max(self._newest, stamp)
            if self._newest - self._pruned_at >= PRUNE_EVERY_S:
                self._tree.forget_before(self._newest - CACHE_S)
                self._pruned_at = self._newest
            self._changed.notify_all()
        return problems

    def lookup(self, base: str, frame: str, stamp: float, *, max_gap: float, timeout_s: float) -> NDArray[np.float64]:
        """``T_base_frame`` at ``stamp`` (seconds), waiting up to ``timeout_s`` for transforms still to come.

        Raises
        ------
        TransformUnavailable
            Not available within the timeout; the message says which edge or frame was missing.
        """
        deadline = time.monotonic() + max(timeout_s, 0.0)
        with self._changed:
            while True:
                try:
                    return self._tree.lookup(base, frame, stamp, max_gap, wait_for_later=True)
                except (InputError, TransformUnavailable) as exc:  # unknown frames or samples not there yet
                    why = str(exc)
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TransformUnavailable(why)
                self._changed.wait(left)

    def available(self, base: str, frame: str, stamp: float, *, max_gap: float) -> bool:
        """Whether :meth:`lookup` would answer now, without waiting."""
        try:
            self.lookup(base, frame, stamp, max_gap=max_gap, timeout_s=0.0)
        except TransformUnavailable:
            return False
        return True


__all__ = ["CACHE_S", "LiveTransforms"]
