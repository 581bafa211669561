"""Simulated scenes: fruit (spheres, ellipsoids) and occluders (leaves, stems), with ground truth.

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

from ..checks import check_quaternion_xyzw, is_real, vector
from ..errors import InputError
from ..geometry.ellipsoid import Ellipsoid, equivalent_radius
from ..geometry.orientation import rotation_from_quaternion_xyzw


@dataclass(frozen=True)
class Sphere:
    """A fruit: centre (3,) metres base frame, radius metres, label."""

    centre: NDArray[np.float64]
    radius: float
    label: str = "tomato"

    @property
    def semi_axes(self) -> NDArray[np.float64]:
        """``(r, r, r)``, metres."""
        return np.full(3, float(self.radius))

    @property
    def ellipsoid(self) -> Ellipsoid:
        """The fruit as a :class:`~monovisual3d.geometry.Ellipsoid` (identity orientation)."""
        return Ellipsoid.sphere(self.centre, self.radius)

    def to_dict(self) -> dict[str, Any]:
        return {"position": [float(v) for v in self.centre], "radius": float(self.radius), "label": self.label}


@dataclass(frozen=True)
class EllipsoidFruit:
    """A non-spherical fruit: an ellipsoid (pepper, cucumber, oblate tomato, apple, plum).

    Attributes
    ----------
    centre : ndarray, shape (3,), metres, base frame
    semi_axes : ndarray, shape (3,), metres, along the columns of :attr:`rotation`
    quaternion_xyzw : ndarray, shape (4,), orientation of the axes in the base frame
    label : str
    """

    centre: NDArray[np.float64]
    semi_axes: NDArray[np.float64]
    quaternion_xyzw: NDArray[np.float64]
    label: str = "fruit"

    def __post_init__(self) -> None:
        e = Ellipsoid(self.centre, self.semi_axes, self.quaternion_xyzw)  # validates
        object.__setattr__(self, "centre", e.centre_base)
        object.__setattr__(self, "semi_axes", e.semi_axes)
        object.__setattr__(self, "quaternion_xyzw", e.quaternion_xyzw)

    @classmethod
    def from_ellipsoid(cls, ellipsoid: Ellipsoid, label: str = "fruit") -> EllipsoidFruit:
        return cls(ellipsoid.centre_base, ellipsoid.semi_axes, ellipsoid.quaternion_xyzw, label)

    @property
    def ellipsoid(self) -> Ellipsoid:
        return Ellipsoid(self.centre, self.semi_axes, self.quaternion_xyzw)

    @property
    def radius(self) -> float:
        """Volume-equivalent radius, metres (what sphere-only code sees)."""
        return float(equivalent_radius(self.semi_axes))

    @property
    def rotation(self) -> NDArray[np.float64]:
        """``R_base_ellipsoid`` (3, 3): the axes (columns) in the base frame."""
        return rotation_from_quaternion_xyzw(self.quaternion_xyzw)

    def to_dict(self) -> dict[str, Any]:
        """The truth format: ``position``, ``radius`` (volume-equivalent), ``label``, ``shape``,
        ``semi_axes``, ``quaternion_xyzw``, ``volume_m3``."""
        e = self.ellipsoid.to_dict()
        return {
            "position": e["position"],
            "radius": e["radius"],
            "label": self.label,
            **{k: e[k] for k in ("shape", "semi_axes", "quaternion_xyzw", "volume_m3")},
        }


#: A fruit of a scene.
Fruit = Sphere | EllipsoidFruit


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

    fruits: tuple[Fruit, ...]
    occluders: tuple[Occluder, ...] = ()
    name: str = "scene"
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def centres(self) -> NDArray[np.float64]:
        """Fruit centres, shape (M, 3), metres, base frame."""
        return np.array([f.centre for f in self.fruits]).reshape(-1, 3)

    @property
    def radii(self) -> NDArray[np.float64]:
        """Fruit radii, shape (M,), metres (volume-equivalent for ellipsoids)."""
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
        base frame; optional ``label``), or of ellipsoids
        ``{"position": [x, y, z], "semi_axes": [a, b, c], "quaternion_xyzw": [x, y, z, w]}``
        (quaternion optional, identity by default; ``radius`` and ``volume_m3`` are then derived and ignored);
        ``occluders`` a list of leaves
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
        fruits = tuple(_fruit(o, f"objects[{i}]") for i, o in enumerate(objects))
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
        from .._structured import read_structured_file

        data = read_structured_file(path)  # its errors name the file already
        try:
            return cls.from_dict(data)
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None


#: What a scene file holds, for messages.
SCENE_FIELDS = '{"objects": [{"position": [x, y, z], "radius": r}, ...], "occluders": [...] (optional)}'
FRUIT_FIELDS = '{"position": [x, y, z], "radius": r, "label": "tomato" (optional)}'
ELLIPSOID_FIELDS = '{"position": [x, y, z], "semi_axes": [a, b, c], "quaternion_xyzw": [x, y, z, w] (optional)}'


def _fruit(o: Any, where: str) -> Fruit:
    if isinstance(o, dict) and "semi_axes" in o:
        return _ellipsoid_fruit(o, where)
    return _sphere(o, where)


def _ellipsoid_fruit(o: dict[str, Any], where: str) -> EllipsoidFruit:
    if "position" not in o:
        raise InputError(f"{where}.position: missing field, expected an ellipsoid fruit {ELLIPSOID_FIELDS}")
    s = vector(o["semi_axes"], 3, f"{where}.semi_axes")
    for i, v in enumerate(s):
        _positive(float(v), f"{where}.semi_axes[{i}]")
    q = vector(o.get("quaternion_xyzw", [0.0, 0.0, 0.0, 1.0]), 4, f"{where}.quaternion_xyzw")
    q = check_quaternion_xyzw(q, where=f"{where}.quaternion_xyzw")
    label = o.get("label", "fruit")
    if not isinstance(label, str):
        raise InputError(f"{where}.label: expected a string, got {label!r}")
    return EllipsoidFruit(vector(o["position"], 3, f"{where}.position"), s, q, label)


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
    return Sphere(vector(o["position"], 3, f"{where}.position"), radius, label)


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
            _positive(float(v), f"{where}.half_size[{i}]") for i, v in enumerate(vector(o["half_size"], 2, f"{where}.half_size"))
        )
        return Leaf(
            vector(o["centre"], 3, f"{where}.centre"),
            vector(o["axis_u"], 3, f"{where}.axis_u"),
            vector(o["axis_v"], 3, f"{where}.axis_v"),
            (hu, hv),
        )
    return Stem(
        vector(o["start"], 3, f"{where}.start"), vector(o["end"], 3, f"{where}.end"), _positive(o["radius"], f"{where}.radius")
    )


def _positive(value: Any, where: str) -> float:
    if not is_real(value) or not (np.isfinite(value) and value > 0):
        raise InputError(f"{where}: expected a positive number of metres, got {value!r}")
    return float(value)
