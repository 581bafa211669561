"""Shared parsing helpers of the readers: text files, YAML (with OpenCV tags), numbers.

Every helper raises :class:`~monovisual3d.errors.InputError` with a one-line
message that names the source and the field; none lets another exception out
for malformed content.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from .. import _structured
from ..errors import InputError
from ..limits import MAX_ABS_ANGLE_RAD, MAX_ABS_POSITION_M, MAX_ABS_STAMP_S, MAX_TABLE_ROWS

read_text = _structured.read_text
load_json = _structured.load_json


def read_table_text(path: str | Path) -> str:
    """:func:`read_text` of a table (CSV, TUM, YOLO labels), refused when it has more than
    :data:`~monovisual3d.limits.MAX_TABLE_ROWS` lines, before any line is parsed."""
    text = read_text(path)
    check_rows(text.count("\n"), str(path), "lines")
    return text


def check_rows(n: int, where: str, what: str = "rows") -> None:
    """Refuse a table or list of more than :data:`~monovisual3d.limits.MAX_TABLE_ROWS` items (one line naming ``where``)."""
    if n > MAX_TABLE_ROWS:
        raise InputError(f"{where}: {n:,} {what}, more than the {MAX_TABLE_ROWS:,} accepted in one file")


# ---------------------------------------------------------------------- YAML
class _Loader(_structured.SafeLoader):
    """The safe, bounded YAML loader that also reads OpenCV FileStorage files.

    ``!!opencv-matrix`` (and other ``!!opencv-*`` tags) become plain mappings with
    ``type_id`` set, like OpenCV's JSON output; other tags are refused.
    """

    allow_tag_prefixes = ("tag:yaml.org,2002:opencv-",)


def _construct_opencv(loader: yaml.SafeLoader, suffix: str, node: yaml.Node) -> dict[str, Any]:
    if not isinstance(node, yaml.MappingNode):
        raise yaml.constructor.ConstructorError(None, None, f"!!opencv-{suffix} must be a mapping", node.start_mark)
    data = loader.construct_mapping(node, deep=True)
    return {"type_id": f"opencv-{suffix}", **data}


_Loader.add_multi_constructor("tag:yaml.org,2002:opencv-", _construct_opencv)

_OPENCV_DIRECTIVE = re.compile(r"\A\s*%YAML[: ]?1\.\d+[^\n]*\n")


def load_yaml(text: str, source: str) -> Any:
    """Parse YAML text, accepting OpenCV FileStorage's ``%YAML:1.0`` header and ``!!opencv-matrix`` tags."""
    text = _OPENCV_DIRECTIVE.sub("", text, count=1)
    return _structured.load_yaml(text, source, _Loader)


def load_structured(path: str | Path) -> Any:
    """Read a JSON or YAML file; the suffix decides, otherwise the first character (``{``/``[``: JSON)."""
    text = read_text(path)
    suffix = Path(path).suffix.lower()
    if suffix == ".json" or (suffix not in (".yaml", ".yml") and text.lstrip()[:1] in ("{", "[")):
        return load_json(text, str(path))
    return load_yaml(text, str(path))


# ---------------------------------------------------------------------- values
def where_join(where: str, key: str | int) -> str:
    """JSON-path style join: ``where.key`` or ``where[3]``."""
    if isinstance(key, int):
        return f"{where}[{key}]"
    return f"{where}.{key}" if where else str(key)


def check_translations(T: NDArray[np.float64], where: str) -> None:
    """Reject transforms (shape (..., 4, 4)) whose translation exceeds :data:`MAX_ABS_POSITION_M`."""
    t = np.abs(np.asarray(T)[..., :3, 3])
    if t.size and not np.max(t) <= MAX_ABS_POSITION_M:
        i = int(np.argmax(np.max(t.reshape(-1, 3), axis=1)))
        which = f" (pose {i})" if np.asarray(T).ndim == 3 else ""
        raise InputError(f"{where}{which}: position coordinate {np.max(t):.3g} m, beyond {MAX_ABS_POSITION_M:g} m (wrong units?)")


def check_stamp(value: float, where: str) -> float:
    """A time stamp within :data:`MAX_ABS_STAMP_S` seconds."""
    if not abs(value) <= MAX_ABS_STAMP_S:
        raise InputError(f"{where}: stamp {value:.6g} s, beyond {MAX_ABS_STAMP_S:g} s")
    return value


def check_angles(values: Any, where: str) -> NDArray[np.float64]:
    """Angles (radians) within :data:`MAX_ABS_ANGLE_RAD`."""
    arr = np.asarray(values, dtype=float)
    if not np.all(np.abs(arr) <= MAX_ABS_ANGLE_RAD):
        raise InputError(
            f"{where}: angle {np.max(np.abs(arr)):.3g} rad, beyond {MAX_ABS_ANGLE_RAD:g} rad (degrees given as radians?)"
        )
    return arr


def stamp_from_name(name: str) -> float | None:
    """Seconds from a numeric file stem (``1700000000.25.png`` or nanoseconds ``1700000000250000000.png``).

    Returns None for stems that are not a plain number.
    """
    stem = Path(name).name
    for suffix in Path(stem).suffixes[::-1]:
        if not re.fullmatch(r"\.\d+", suffix):
            stem = stem[: -len(suffix)]
        else:
            break
    if re.fullmatch(r"\d{16,20}", stem):
        return int(stem) * 1e-9
    if re.fullmatch(r"\d+(\.\d+)?", stem):
        return float(stem)
    return None


def image_key(name: str) -> str:
    """The key used to match an image with its poses and detections: the file name without folders and suffix."""
    base = name.replace("\\", "/").rsplit("/", 1)[-1]
    stem, dot, suffix = base.rpartition(".")
    if dot and stem and not suffix.isdigit():
        return stem
    return base
