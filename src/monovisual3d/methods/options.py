"""Options every method shares: memory budget, compute backend, threads.

Each method's config dataclass has these fields with these defaults and
checks, so ``localize(session, method=..., max_memory=..., backend=...,
threads=...)`` means the same for every method.
"""

from __future__ import annotations

import math
import numbers
import re
from typing import Any

from ..engine.threads import check_threads
from ..errors import InputError
from ..limits import DEFAULT_MAX_BYTES

__all__ = ["DEFAULT_MAX_MEMORY", "check_threads", "format_bytes", "is_real", "parse_bytes"]

#: Default memory budget of one ``localize`` call, bytes (2 GiB).
DEFAULT_MAX_MEMORY = DEFAULT_MAX_BYTES
#: Smallest budget accepted, bytes (below this nothing useful fits).
MIN_MAX_MEMORY = 16 * 1024**2

_UNITS = {"": 1, "b": 1, "k": 1000, "kb": 1000, "kib": 1024, "m": 1000**2, "mb": 1000**2, "mib": 1024**2,
          "g": 1000**3, "gb": 1000**3, "gib": 1024**3, "t": 1000**4, "tb": 1000**4, "tib": 1024**4}  # fmt: skip


def is_real(v: Any) -> bool:
    """A real number (Python or numpy: numpy registers its scalars as :class:`numbers.Real`), not a bool."""
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def parse_bytes(value: Any, name: str = "max_memory") -> int:
    """A memory size in bytes from a number or a string such as ``"2GiB"``, ``"512 MB"``, ``"1.5g"``.

    Examples
    --------
    >>> parse_bytes("2GiB"), parse_bytes(1e9), parse_bytes("512 mb")
    (2147483648, 1000000000, 512000000)
    """
    if isinstance(value, str):
        m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([a-zA-Z]*)\s*", value)
        if m is None or m.group(2).lower() not in _UNITS:
            raise InputError(f"{name}: got {value[:40]!r}, expected a size in bytes such as 2GiB, 512MiB or 1e9")
        number = float(m.group(1)) * _UNITS[m.group(2).lower()]
    elif is_real(value):
        number = float(value)
    else:
        raise InputError(f"{name}: got {type(value).__name__}, expected a size in bytes such as 2GiB or 1e9")
    if not (math.isfinite(number) and number >= MIN_MAX_MEMORY):
        raise InputError(f"{name}: got {value!r}, expected at least {MIN_MAX_MEMORY // 1024**2} MiB")
    return int(min(number, 2**62))


def format_bytes(n: float) -> str:
    """``1.5 GiB``-style text of a byte count."""
    for unit, size in (("GiB", 1024**3), ("MiB", 1024**2), ("KiB", 1024)):
        if n >= size:
            v = n / size
            return f"{v:.1f} {unit}" if v < 1e5 else f"{v:.4g} {unit}"
    return f"{int(n)} B"
