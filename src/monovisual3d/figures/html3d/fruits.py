"""The estimated fruit as the 3D view draws them, read from a result (object, dict or file)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._structured import read_structured_file
from ...checks import check_quaternion_xyzw, finite_number, vector
from ...errors import InputError
from ...result import Result


@dataclass(frozen=True)
class Fruit:
    """One estimated fruit as the view draws it.

    Attributes
    ----------
    position : ndarray, shape (3,), float64, metres, base frame
    score : float, the method's score (colour)
    semi_axes : ndarray, shape (3,), metres, the shape's semi-axes (all equal for a sphere), or None when unknown
    R_base_fruit : ndarray, shape (3, 3), rotation of the shape's axes into the base frame
    covariance : ndarray, shape (3, 3), m^2, base frame, or None
    associations : dict view index -> detection index
    """

    position: NDArray[np.float64]
    score: float
    semi_axes: NDArray[np.float64] | None = None
    R_base_fruit: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))
    covariance: NDArray[np.float64] | None = None
    associations: dict[int, int] = field(default_factory=dict)


def fruits_from_dict(data: Any) -> list[Fruit]:
    """The estimated fruit of a result (``{"objects": [...]}`` as ``localize --output`` writes it).

    Each object needs ``position``; ``score``, ``radius``, ``semi_axes`` with ``quaternion_xyzw``,
    ``covariance`` and ``associations`` are used when present.

    Raises
    ------
    InputError
        ``objects[i].field: problem``.

    Examples
    --------
    >>> f = fruits_from_dict({"objects": [{"position": [0.5, 0, 0.4], "score": 9.0, "radius": 0.03}]})
    >>> f[0].semi_axes.tolist()
    [0.03, 0.03, 0.03]
    """
    if not isinstance(data, dict) or not isinstance(data.get("objects"), list):
        raise InputError('objects: missing field, expected {"objects": [{"position": [x, y, z]}, ...]}')
    out = []
    for i, o in enumerate(data["objects"]):
        where = f"objects[{i}]"
        if not isinstance(o, dict):
            raise InputError(f"{where}: expected an object, got {type(o).__name__}")
        if "position" not in o:
            raise InputError(f"{where}.position: missing field, expected [x, y, z] in metres")
        position = vector(o["position"], 3, f"{where}.position")
        score = finite_number(o.get("score", 0.0), f"{where}.score")
        semi_axes, R = None, np.eye(3)
        if o.get("semi_axes") is not None:
            semi_axes = vector(o["semi_axes"], 3, f"{where}.semi_axes")
            if q := o.get("quaternion_xyzw"):
                R = _rotation_from_quaternion_xyzw(check_quaternion_xyzw(q, where=f"{where}.quaternion_xyzw"))
        elif o.get("radius") is not None:
            semi_axes = np.full(3, finite_number(o["radius"], f"{where}.radius"))
        if semi_axes is not None and not np.all(semi_axes > 0):
            name = "semi_axes" if o.get("semi_axes") is not None else "radius"
            raise InputError(f"{where}.{name}: expected positive metres, got {o[name]!r}")
        covariance = None
        if o.get("covariance") is not None:
            try:
                covariance = np.array(o["covariance"], dtype=float)
            except (TypeError, ValueError):
                covariance = None
            if covariance is None or covariance.shape != (3, 3) or not np.all(np.isfinite(covariance)):
                raise InputError(f"{where}.covariance: expected a 3 x 3 matrix of finite numbers (m^2)")
        associations: dict[int, int] = {}
        for k, v in (o.get("associations") or {}).items():
            try:
                associations[int(k)] = int(v)
            except (TypeError, ValueError):
                raise InputError(f"{where}.associations.{k}: expected view index -> detection index, got {v!r}") from None
        out.append(Fruit(position, score, semi_axes, R, covariance, associations))
    return out


def load_fruits(source: Result | dict[str, Any] | str | Path) -> list[Fruit]:
    """:func:`fruits_from_dict` of a :class:`~monovisual3d.result.Result`, a dict or a result file (JSON/YAML)."""
    if isinstance(source, Result):
        return fruits_from_dict(source.to_dict())
    if isinstance(source, dict):
        return fruits_from_dict(source)
    try:
        return fruits_from_dict(read_structured_file(source))
    except InputError as exc:
        raise InputError(f"{source}: {exc}") if not str(exc).startswith(f"{source}:") else exc from None


def _rotation_from_quaternion_xyzw(q: NDArray[np.float64]) -> NDArray[np.float64]:
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(q).as_matrix()
