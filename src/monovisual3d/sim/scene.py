"""Simulated scenes: spherical fruit and occluders (leaves, stems), with ground truth.

All positions in metres, base frame. A scene saves to / loads from JSON; its
``truth`` part is the ground-truth file format of ``monovisual3d evaluate``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError


@dataclass(frozen=True)
class Sphere:
    """A fruit: centre (3,) metres base frame, radius metres, label."""

    centre: NDArray[np.float64]
    radius: float
    label: str = "tomato"

    def to_dict(self) -> dict[str, Any]:
        return {"position": [float(v) for v in self.centre], "radius": float(self.radius), "label": self.label}


@dataclass(frozen=True)
class Leaf:
    """A planar rectangular occluder.

    Attributes
    ----------
    centre : ndarray, shape (3,), metres, base frame
    axis_u, axis_v : ndarray, shape (3,), orthogonal unit vectors spanning the leaf plane
    half_size : tuple (hu, hv), metres, half extents along axis_u and axis_v
    """

    centre: NDArray[np.float64]
    axis_u: NDArray[np.float64]
    axis_v: NDArray[np.float64]
    half_size: tuple[float, float]

    @property
    def normal(self) -> NDArray[np.float64]:
        n = np.cross(self.axis_u, self.axis_v)
        return n / np.linalg.norm(n)

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "leaf",
            "centre": self.centre.tolist(),
            "axis_u": self.axis_u.tolist(),
            "axis_v": self.axis_v.tolist(),
            "half_size": list(self.half_size),
        }


@dataclass(frozen=True)
class Stem:
    """A thin cylinder occluder from ``start`` to ``end`` (metres, base frame) with ``radius``."""

    start: NDArray[np.float64]
    end: NDArray[np.float64]
    radius: float

    def to_dict(self) -> dict[str, Any]:
        return {"type": "stem", "start": self.start.tolist(), "end": self.end.tolist(), "radius": self.radius}


Occluder = Leaf | Stem


@dataclass(frozen=True)
class Scene:
    """Fruit plus occluders."""

    fruits: tuple[Sphere, ...]
    occluders: tuple[Occluder, ...] = ()
    name: str = "scene"
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def centres(self) -> NDArray[np.float64]:
        """Fruit centres, shape (M, 3), metres, base frame."""
        return np.array([f.centre for f in self.fruits]).reshape(-1, 3)

    @property
    def radii(self) -> NDArray[np.float64]:
        """Fruit radii, shape (M,), metres."""
        return np.array([f.radius for f in self.fruits], dtype=float)

    def truth_dict(self) -> dict[str, Any]:
        """Ground truth in the format read by ``monovisual3d evaluate``."""
        return {"objects": [f.to_dict() for f in self.fruits]}

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "objects": [f.to_dict() for f in self.fruits],
            "occluders": [o.to_dict() for o in self.occluders],
            "metadata": self.metadata,
        }

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=2) + "\n")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scene:
        try:
            fruits = tuple(
                Sphere(np.asarray(o["position"], dtype=float), float(o["radius"]), o.get("label", "tomato"))
                for o in data["objects"]
            )
            occ: list[Occluder] = []
            for o in data.get("occluders", []):
                if o["type"] == "leaf":
                    occ.append(
                        Leaf(
                            np.asarray(o["centre"], float),
                            np.asarray(o["axis_u"], float),
                            np.asarray(o["axis_v"], float),
                            tuple(o["half_size"]),  # type: ignore[arg-type]
                        )
                    )
                elif o["type"] == "stem":
                    occ.append(Stem(np.asarray(o["start"], float), np.asarray(o["end"], float), float(o["radius"])))
                else:
                    raise InputError(f"occluders: unknown type {o['type']!r}, expected 'leaf' or 'stem'")
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"scene: malformed scene description ({exc})") from None
        return cls(fruits, tuple(occ), data.get("name", "scene"), data.get("metadata", {}))

    @classmethod
    def load(cls, path: str | Path) -> Scene:
        from ..session import read_structured_file

        try:
            return cls.from_dict(read_structured_file(path))
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
