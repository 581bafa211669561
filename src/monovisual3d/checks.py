"""Low-level checks of parsed input (JSON/YAML objects and numbers), each failing with one line that names the path.

The core's session loader and camera use these; they import nothing of the package but :mod:`errors` and
:mod:`limits`, so any module of the core may use them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import limits
from .errors import InputError, excerpt, one_line


def expect_object(data: Any, where: str) -> None:
    """Refuse anything but a mapping (a JSON object) at ``where``."""
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected an object, got {type(data).__name__}")


def reject_unknown(data: dict[str, Any], allowed: set[str], where: str) -> None:
    """Refuse a key of ``data`` outside ``allowed``, naming the first one (in a stable order)."""
    unknown = sorted(set(data) - allowed, key=excerpt)  # YAML keys may be numbers or None, not only text
    if unknown:
        key = unknown[0]
        name = one_line(key, limits.EXCERPT_CHARS) if isinstance(key, str) else excerpt(key)  # keep the message one line
        path = f"{where}.{name}" if where else name
        raise InputError(f"{path}: unknown field, expected one of {sorted(allowed)}")


def finite_number(value: Any, where: str, bound: float | None = None, unit: str = "") -> float:
    """A finite float (not a bool); with ``bound``, ``|value| <= bound`` (``unit`` names it in the message).

    Examples
    --------
    >>> finite_number(2, "camera.fx")
    2.0
    >>> finite_number(float("nan"), "camera.fx")
    Traceback (most recent call last):
    ...
    monovisual3d.errors.InputError: camera.fx: got nan, expected a finite number
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"{where}: expected a number, got {excerpt(value)}")
    try:
        out = float(value)
    except OverflowError:
        raise InputError(f"{where}: got {excerpt(value)}, too large for a number") from None
    if not math.isfinite(out):
        raise InputError(f"{where}: got {out}, expected a finite number")
    if bound is not None and not abs(out) <= bound:
        raise InputError(f"{where}: got {out:.6g}, beyond the {bound:g}{' ' + unit if unit else ''} accepted")
    return out
