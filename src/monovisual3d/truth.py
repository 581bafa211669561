"""Reading ground-truth and estimate files for evaluation.

Truth: ``{"objects": [{"position": [x, y, z], "radius": r, "label": "..."}]}``
(metres, base frame; radius and label optional). Estimates: the JSON that
``monovisual3d localize`` writes (``{"objects": [{"position": ..., ...}]}``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import InputError, one_line
from .limits import MAX_ABS_POSITION_M
from .session import _check_position, _number, _vector, read_structured_file


@dataclass(frozen=True)
class ObjectSet:
    """Positions (M, 3) in metres, base frame, with optional radii (M,) (NaN where unknown) and labels.

    ``from_result`` is True when the file is a ``localize`` result (it has a ``method`` field).
    """

    positions: NDArray[np.float64]
    radii: NDArray[np.float64]
    labels: tuple[str | None, ...]
    from_result: bool = False

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
        raise InputError(f"{name}: {exc}" if name else str(exc)) from None


def objects_from_dict(data: Any, *, allow_empty: bool = True) -> ObjectSet:
    if not isinstance(data, dict) or "objects" not in data:
        raise InputError('objects: missing field, expected {"objects": [{"position": [x, y, z]}, ...]}')
    objs = data["objects"]
    if not isinstance(objs, list):
        raise InputError(f"objects: expected a list, got {type(objs).__name__}")
    if not objs and not allow_empty:
        raise InputError("objects: empty, expected at least one object")
    pos, radii, labels = [], [], []
    for i, o in enumerate(objs):
        if not isinstance(o, dict):
            raise InputError(f"objects[{i}]: expected an object, got {type(o).__name__}")
        if "position" not in o:
            raise InputError(f"objects[{i}].position: missing field, expected [x, y, z] in metres")
        p = _vector(o["position"], 3, f"objects[{i}].position")
        _check_position(p, f"objects[{i}].position")
        pos.append(p)
        r = o.get("radius")
        if r is None:
            radii.append(np.nan)
        else:
            r = _number(r, f"objects[{i}].radius", MAX_ABS_POSITION_M, "m")
            if r <= 0:
                raise InputError(f"objects[{i}].radius: got {r}, expected a positive number of metres")
            radii.append(r)
        labels.append(o.get("label"))
    return ObjectSet(np.array(pos).reshape(-1, 3), np.array(radii, dtype=float), tuple(labels), "method" in data)
