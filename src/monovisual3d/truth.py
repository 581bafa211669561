"""Reading ground-truth and estimate files for evaluation.

Truth: ``{"objects": [{"position": [x, y, z], "radius": r, "label": "..."}]}``
(metres, base frame; radius and label optional), and for non-spherical objects
``semi_axes`` ([a, b, c], metres), ``quaternion_xyzw`` and ``volume_m3`` (optional).
Estimates: the JSON that ``monovisual3d localize`` writes (``{"objects": [{"position": ..., ...}]}``).

Semi-axes default to ``(r, r, r)`` where only a radius is given, and volumes to
``4/3 pi a b c``, so that sphere estimates can be compared with ellipsoid truth.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._structured import read_structured_file
from .checks import check_position, expect_list, finite_number, vector
from .errors import InputError, one_line
from .file_kinds import wrong_kind
from .limits import MAX_ABS_POSITION_M


@dataclass(frozen=True)
class ObjectSet:
    """Positions (M, 3) in metres, base frame, with optional radii (M,) (NaN where unknown) and labels.

    ``from_result`` is True when the file is a ``localize`` result (it has a ``method`` field).
    ``semi_axes`` (M, 3) and ``volumes`` (M,) (metres, m^3; NaN where unknown) come from the
    objects' ``semi_axes``/``volume_m3`` or from their radius; ``has_shapes`` is True when
    some object gave ``semi_axes`` explicitly.
    """

    positions: NDArray[np.float64]
    radii: NDArray[np.float64]
    labels: tuple[str | None, ...]
    from_result: bool = False
    semi_axes: NDArray[np.float64] | None = None
    volumes: NDArray[np.float64] | None = None
    has_shapes: bool = False

    @property
    def has_radii(self) -> bool:
        return bool(len(self.radii)) and bool(np.all(np.isfinite(self.radii)))


def load_objects(source: str | Path | dict[str, Any], *, allow_empty: bool = True) -> ObjectSet:
    """Read ``{"objects": [...]}`` from a file or dict, with one-line errors naming the field."""
    name = None if isinstance(source, dict) else one_line(str(source))
    data = source if isinstance(source, dict) else read_structured_file(source)
    try:
        return objects_from_dict(data, allow_empty=allow_empty)
    except InputError as exc:
        # a session (or another kind) given in place of a result or truth file: say what it is
        message = wrong_kind(data, "objects") or str(exc)
        raise InputError(f"{name}: {message}" if name else message) from None


def objects_from_dict(data: Any, *, allow_empty: bool = True) -> ObjectSet:
    if not isinstance(data, dict) or "objects" not in data:
        raise InputError('objects: missing field, expected {"objects": [{"position": [x, y, z]}, ...]}')
    objs = expect_list(data["objects"], "objects")
    if not objs and not allow_empty:
        raise InputError("objects: empty, expected at least one object")
    pos, radii, labels, semi, volumes = [], [], [], [], []
    has_shapes = False
    for i, o in enumerate(objs):
        if not isinstance(o, dict):
            raise InputError(f"objects[{i}]: expected an object, got {type(o).__name__}")
        if "position" not in o:
            raise InputError(f"objects[{i}].position: missing field, expected [x, y, z] in metres")
        p = vector(o["position"], 3, f"objects[{i}].position")
        check_position(p, f"objects[{i}].position")
        pos.append(p)
        r = o.get("radius")
        if r is None:
            radii.append(np.nan)
        else:
            r = finite_number(r, f"objects[{i}].radius", MAX_ABS_POSITION_M, "m")
            if r <= 0:
                raise InputError(f"objects[{i}].radius: got {r}, expected a positive number of metres")
            radii.append(r)
        labels.append(o.get("label"))
        if o.get("semi_axes") is not None:
            has_shapes = True
            s = vector(o["semi_axes"], 3, f"objects[{i}].semi_axes")
            if not np.all(s > 0):
                raise InputError(f"objects[{i}].semi_axes: got {s.tolist()}, expected three positive lengths in metres")
        else:
            s = np.full(3, radii[-1])
        semi.append(s)
        v = o.get("volume_m3")
        if v is not None:
            v = finite_number(v, f"objects[{i}].volume_m3")
            if v <= 0:
                raise InputError(f"objects[{i}].volume_m3: got {v}, expected a positive volume in m^3")
        else:
            v = 4.0 / 3.0 * np.pi * float(np.prod(s))
        volumes.append(v)
    return ObjectSet(
        np.array(pos).reshape(-1, 3),
        np.array(radii, dtype=float),
        tuple(labels),
        "method" in data,
        np.array(semi, dtype=float).reshape(-1, 3),
        np.array(volumes, dtype=float),
        has_shapes,
    )
