"""The session's model: camera, views (pose + detections) and optional workspace, as frozen dataclasses.

A :class:`Session` is the input contract of :func:`monovisual3d.localize`; :mod:`.load` builds one from
a JSON or YAML file, checking every field.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from ..errors import InputError
from ..frames import position_quaternion_from_transform
from ..verdict import Cause


def _fields_equal(self: Any, other: object) -> bool:
    """Dataclass equality that compares ndarray fields by value (the generated ``__eq__`` raises on arrays)."""
    if other.__class__ is not self.__class__:
        return NotImplemented
    for f in fields(self):
        a, b = getattr(self, f.name), getattr(other, f.name)
        if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
            if not np.array_equal(a, b):
                return False
        elif a != b:
            return False
    return True


@dataclass(frozen=True, eq=False)
class Detection:
    """One detected object in one image.

    Attributes
    ----------
    bbox_xyxy : ndarray, shape (4,), float64, pixels ``(x1, y1, x2, y2)``, x1 < x2, y1 < y2
    score : float or None, detector confidence in [0, 1]
    label : str or None
    mask : dict or None
        Optional instance mask: ``{"polygon": [[u, v], ...]}`` or COCO RLE
        ``{"size": [height, width], "counts": ...}``.
    track : int or None, >= 0: the object this box belongs to, when the association across
        views is known (a tracker, an annotated data set); methods that associate may use it
    """

    bbox_xyxy: NDArray[np.float64]
    score: float | None = None
    label: str | None = None
    mask: dict[str, Any] | None = None
    track: int | None = None

    __eq__ = _fields_equal  # ndarray fields: compare by value, not elementwise

    def __post_init__(self) -> None:
        """Refuse a box that no detector draws (built in code, not read from a file, which checks more): four finite
        numbers with ``x1 <= x2`` and ``y1 <= y2``."""
        box = np.asarray(self.bbox_xyxy, dtype=float)
        if box.shape != (4,) or not np.all(np.isfinite(box)) or box[2] < box[0] or box[3] < box[1]:
            raise InputError(
                f"Detection.bbox_xyxy: got {np.asarray(self.bbox_xyxy).tolist()}, expected 4 finite pixel coordinates "
                "(x1, y1, x2, y2) with x1 <= x2 and y1 <= y2"
            )

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"bbox_xyxy": [float(v) for v in self.bbox_xyxy]}
        if self.score is not None:
            out["score"] = float(self.score)
        if self.label is not None:
            out["label"] = self.label
        if self.mask is not None:
            out["mask"] = self.mask
        if self.track is not None:
            out["track"] = int(self.track)
        return out


@dataclass(frozen=True, eq=False)
class View:
    """One camera pose with the detections made there.

    Attributes
    ----------
    T_base_optical : ndarray, shape (4, 4), the optical frame expressed in the base frame
    detections : tuple of Detection
    image : str or None, the image file the detections came from
    stamp : float or None, seconds
    """

    T_base_optical: NDArray[np.float64]
    detections: tuple[Detection, ...] = ()
    image: str | None = None
    stamp: float | None = None

    __eq__ = _fields_equal

    @property
    def boxes_xyxy(self) -> NDArray[np.float64]:
        """All boxes, shape (N, 4), pixels."""
        if not self.detections:
            return np.zeros((0, 4))
        return np.stack([d.bbox_xyxy for d in self.detections])

    def to_dict(self) -> dict[str, Any]:
        position, q = position_quaternion_from_transform(self.T_base_optical)
        out: dict[str, Any] = {
            "pose": {"position": position.tolist(), "quaternion_xyzw": q.tolist()},
            "detections": [d.to_dict() for d in self.detections],
        }
        if self.image is not None:
            out["image"] = self.image
        if self.stamp is not None:
            out["stamp"] = self.stamp
        return out


@dataclass(frozen=True, eq=False)
class Workspace:
    """Axis-aligned box in the base frame, metres: ``min`` (3,), ``max`` (3,)."""

    min: NDArray[np.float64]
    max: NDArray[np.float64]

    __eq__ = _fields_equal

    def to_dict(self) -> dict[str, Any]:
        return {"min": self.min.tolist(), "max": self.max.tolist()}


@dataclass(frozen=True)
class Session:
    """A validated session: camera, views and optional workspace.

    ``causes`` holds what the loader found wrong with the input as written (boxes past the image, stretched, or
    with x and y swapped: :func:`.diagnose.raw_box_causes`), for :func:`.diagnose.check_session` to report.
    """

    camera: Camera
    views: tuple[View, ...]
    workspace: Workspace | None = None
    source: str | None = field(default=None, compare=False)
    causes: tuple[Cause, ...] = field(default=(), compare=False)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "camera": self.camera.to_dict(),
            "pose_frame": "optical",
            "views": [v.to_dict() for v in self.views],
        }
        if self.workspace is not None:
            out["workspace"] = self.workspace.to_dict()
        return out

    def to_json(self, path: str | Path | None = None, indent: int = 2) -> str:
        """The session as JSON text; also written to ``path`` when given."""
        text = json.dumps(self.to_dict(), indent=indent)
        if path is not None:
            Path(path).write_text(text + "\n")
        return text
