"""A small ROS-style transform tree: static and time-stamped transforms, chained on lookup.

Each edge stores ``T_parent_child`` (ROS ``TransformStamped``: ``header.frame_id`` is
the parent, ``child_frame_id`` the child). :meth:`TransformTree.lookup` chains the
edges from ``base`` to ``frame`` through their common ancestor, interpolating every
time-stamped edge at the requested time with :func:`~monovisual3d.io.poses.interpolate_poses`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError, excerpt
from ..frames import invert_transform
from .poses import interpolate_poses


class TransformUnavailable(Exception):
    """A transform is not available at the requested time (the message says which and why)."""


@dataclass
class _Edge:
    parent: str
    static: NDArray[np.float64] | None = None
    stamps: list[float] = field(default_factory=list)
    transforms: list[NDArray[np.float64]] = field(default_factory=list)
    _sorted: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None

    def samples(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if self._sorted is None:
            st = np.asarray(self.stamps, dtype=float)
            T = np.stack(self.transforms)
            order = np.argsort(st, kind="stable")
            st, T = st[order], T[order]
            keep = np.concatenate([[True], np.diff(st) > 0])  # repeated stamps: keep the first
            self._sorted = (st[keep], T[keep])
        return self._sorted


class TransformTree:
    """Transforms between named frames, static or sampled over time.

    Examples
    --------
    >>> tree = TransformTree()
    >>> T = np.eye(4); T[0, 3] = 1.0
    >>> tree.add("base", "tool", T, stamp=0.0); tree.add("base", "tool", T, stamp=1.0)
    >>> tree.add("tool", "camera", np.eye(4))
    >>> float(tree.lookup("base", "camera", 0.5, max_gap=1.0)[0, 3])
    1.0
    """

    def __init__(self) -> None:
        self._edges: dict[str, _Edge] = {}

    @property
    def frames(self) -> set[str]:
        """All frame names seen."""
        return set(self._edges) | {e.parent for e in self._edges.values()}

    def add(self, parent: str, child: str, T_parent_child: ArrayLike, stamp: float | None = None) -> None:
        """Add ``T_parent_child``; ``stamp`` None makes it static (latest wins)."""
        parent, child = normalise_frame(parent), normalise_frame(child)
        if not parent or not child:
            raise InputError(f"transform {excerpt(parent)} -> {excerpt(child)}: empty frame name")
        if parent == child:
            raise InputError(f"transform {excerpt(parent)} -> {excerpt(child)}: a frame cannot be its own parent")
        T = np.asarray(T_parent_child, dtype=float)
        edge = self._edges.get(child)
        if edge is None:
            edge = self._edges[child] = _Edge(parent)
        elif edge.parent != parent:
            raise InputError(f"frame {excerpt(child)} has two parents, {excerpt(edge.parent)} and {excerpt(parent)}: not a tree")
        if stamp is None:
            edge.static = T
        else:
            edge.stamps.append(float(stamp))
            edge.transforms.append(T)
            edge._sorted = None

    def _chain(self, frame: str) -> list[str]:
        chain = [frame]
        seen = {frame}
        while chain[-1] in self._edges:
            parent = self._edges[chain[-1]].parent
            if parent in seen:
                raise InputError(f"transform tree has a loop through {excerpt(parent)}")
            seen.add(parent)
            chain.append(parent)
        return chain

    def check_connected(self, base: str, frame: str) -> None:
        """Raise InputError when either frame is unknown or they are not connected."""
        base, frame = normalise_frame(base), normalise_frame(frame)
        known = self.frames
        for name, what in ((base, "base frame"), (frame, "camera frame")):
            if name not in known:
                listing = sorted(known)
                raise InputError(f"{what} {excerpt(name)} is not in the transforms; frames seen: {listing[:20]}")
        if not set(self._chain(base)) & set(self._chain(frame)):
            raise InputError(
                f"frames {excerpt(base)} and {excerpt(frame)} are not connected (roots {self._chain(base)[-1]!r} and {self._chain(frame)[-1]!r})"
            )

    def _to_ancestor(self, frame: str, ancestor: str, stamp: float, max_gap: float, wait_for_later: bool) -> NDArray[np.float64]:
        """``T_ancestor_frame`` at ``stamp``."""
        T = np.eye(4)
        node = frame
        while node != ancestor:
            edge = self._edges[node]
            if edge.stamps:
                st, Ts = edge.samples()
                if wait_for_later and st[-1] < stamp:
                    raise TransformUnavailable(
                        f"transform {edge.parent} -> {node}: no sample at or after {stamp:.3f} s yet (latest {st[-1]:.3f} s)"
                    )
                Tq, ok, why = interpolate_poses(st, Ts, [stamp], max_gap)
                if not ok[0]:
                    raise TransformUnavailable(f"transform {edge.parent} -> {node}: {why[0]}")
                T_edge = Tq[0]
            else:
                assert edge.static is not None
                T_edge = edge.static
            T = T_edge @ T
            node = edge.parent
        return T

    def lookup(self, base: str, frame: str, stamp: float, max_gap: float, *, wait_for_later: bool = False) -> NDArray[np.float64]:
        """``T_base_frame`` at ``stamp`` (seconds).

        ``wait_for_later``: a time-stamped edge whose latest sample is before ``stamp`` is not available yet
        (live use, where later samples are still to come: they are waited for, not extrapolated from the
        last one; a recording has all its samples and uses the nearest within ``max_gap``).

        Raises
        ------
        InputError
            Unknown or unconnected frames.
        TransformUnavailable
            A time-stamped edge on the way has no sample within ``max_gap`` of ``stamp`` (or, with
            ``wait_for_later``, none at or after it).
        """
        base, frame = normalise_frame(base), normalise_frame(frame)
        self.check_connected(base, frame)
        up_base, up_frame = self._chain(base), self._chain(frame)
        common = next(f for f in up_frame if f in set(up_base))
        T_common_frame = self._to_ancestor(frame, common, stamp, max_gap, wait_for_later)
        T_common_base = self._to_ancestor(base, common, stamp, max_gap, wait_for_later)
        return invert_transform(T_common_base) @ T_common_frame

    def forget_before(self, stamp: float) -> None:
        """Drop time-stamped samples older than ``stamp`` (seconds), keeping each edge's latest one before it.

        A live buffer calls it to bound its memory (like tf2's cache time); a lookup at ``stamp`` or later
        gives the same answer after it as before.
        """
        for edge in self._edges.values():
            if not edge.stamps:
                continue
            st, Ts = edge.samples()
            first = max(int(np.searchsorted(st, stamp, side="right")) - 1, 0)
            if first > 0:
                edge.stamps, edge.transforms = st[first:].tolist(), list(Ts[first:])
                edge._sorted = None


def normalise_frame(name: str) -> str:
    """ROS 1 frame ids may start with '/': ``/base_link`` and ``base_link`` are the same frame."""
    return str(name).strip().lstrip("/")


__all__ = ["TransformUnavailable", "TransformTree", "normalise_frame"]
