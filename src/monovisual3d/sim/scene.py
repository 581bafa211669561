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
        """A scene from its dict (:meth:`to_dict`): ``objects`` (the fruit) and optional ``occluders``.

        ``objects`` is a list of ``{"position": [x, y, z], "radius": r}`` (metres,
        base frame; optional ``label``); ``occluders`` a list of leaves
        ``{"type": "leaf", "centre", "axis_u", "axis_v", "half_size"}`` and stems
        ``{"type": "stem", "start", "end", "radius"}``.

        Raises
        ------
        InputError
            One line naming the field (``objects[2].radius``) and what was expected.

        Examples
        --------
        >>> Scene.from_dict({"objects": [{"position": [0.6, 0.0, 0.45], "radius": 0.03}]}).radii.tolist()
        [0.03]
        """
        if not isinstance(data, dict):
            raise InputError(f"expected a scene object {SCENE_FIELDS}, got {type(data).__name__}")
        if "objects" not in data:
            if "views" in data:
                raise InputError(f"a session file (it has 'views'), not a scene; a scene file holds {SCENE_FIELDS}")
            raise InputError(f"objects: missing field; a scene file holds {SCENE_FIELDS}")
        objects = data["objects"]
        if not isinstance(objects, list):
            raise InputError(f"objects: expected a list of fruit {FRUIT_FIELDS}, got {type(objects).__name__}")
        fruits = tuple(_sphere(o, f"objects[{i}]") for i, o in enumerate(objects))
        occluders = data.get("occluders", [])
        if not isinstance(occluders, list):
            raise InputError(f"occluders: expected a list of leaves and stems, got {type(occluders).__name__}")
        occ = tuple(_occluder(o, f"occluders[{i}]") for i, o in enumerate(occluders))
        name = data.get("name", "scene")
        metadata = data.get("metadata", {})
        if not isinstance(metadata, dict):
            raise InputError(f"metadata: expected an object, got {type(metadata).__name__}")
        return cls(fruits, occ, str(name), metadata)

    @classmethod
    def load(cls, path: str | Path) -> Scene:
        """Read a scene file (JSON or YAML, :meth:`from_dict`'s format, as :meth:`save` writes it)."""
        from ..session import read_structured_file

        data = read_structured_file(path)  # its errors name the file already
        try:
            return cls.from_dict(data)
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None


#: What a scene file holds, for messages.
SCENE_FIELDS = '{"objects": [{"position": [x, y, z], "radius": r}, ...], "occluders": [...] (optional)}'
FRUIT_FIELDS = '{"position": [x, y, z], "radius": r, "label": "tomato" (optional)}'


def _sphere(o: Any, where: str) -> Sphere:
    if not isinstance(o, dict):
        raise InputError(f"{where}: expected a fruit {FRUIT_FIELDS}, got {type(o).__name__}")
    for k in ("position", "radius"):
        if k not in o:
            raise InputError(f"{where}.{k}: missing field, expected a fruit {FRUIT_FIELDS}")
    radius = _positive(o["radius"], f"{where}.radius")
    label = o.get("label", "tomato")
    if not isinstance(label, str):
        raise InputError(f"{where}.label: expected a string, got {label!r}")
    return Sphere(_vec(o["position"], 3, f"{where}.position"), radius, label)


def _occluder(o: Any, where: str) -> Occluder:
    if not isinstance(o, dict):
        raise InputError(f"{where}: expected an object with type 'leaf' or 'stem', got {type(o).__name__}")
    kind = o.get("type")
    fields = {"leaf": ("centre", "axis_u", "axis_v", "half_size"), "stem": ("start", "end", "radius")}
    if kind not in fields:
        raise InputError(f"{where}.type: got {kind!r}, expected 'leaf' or 'stem'")
    for k in fields[kind]:
        if k not in o:
            raise InputError(f"{where}.{k}: missing field, a {kind} needs {list(fields[kind])}")
    if kind == "leaf":
        hu, hv = (
            _positive(float(v), f"{where}.half_size[{i}]") for i, v in enumerate(_vec(o["half_size"], 2, f"{where}.half_size"))
        )
        return Leaf(
            _vec(o["centre"], 3, f"{where}.centre"),
            _vec(o["axis_u"], 3, f"{where}.axis_u"),
            _vec(o["axis_v"], 3, f"{where}.axis_v"),
            (hu, hv),
        )
    return Stem(
        _vec(o["start"], 3, f"{where}.start"), _vec(o["end"], 3, f"{where}.end"), _positive(o["radius"], f"{where}.radius")
    )


def _vec(value: Any, n: int, where: str) -> NDArray[np.float64]:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if isinstance(value, (str, bytes)) or a.shape != (n,) or not np.all(np.isfinite(a)):
        raise InputError(f"{where}: expected {n} finite numbers (metres), got {value!r}")
    return a


def _positive(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (np.isfinite(value) and value > 0):
        raise InputError(f"{where}: expected a positive number of metres, got {value!r}")
    return float(value)
