"""Low-level checks of parsed input: objects, numbers, vectors, arrays, quaternion norms and byte sizes.

The one home of input validation: the session loader, the camera, the readers of :mod:`monovisual3d.io`,
the configs of the methods and the CLI's options call these, so a number is checked once and its error
reads the same everywhere. Each check fails with one :class:`~monovisual3d.errors.InputError` line
that names the path (``views[3].pose.position[0]: expected a number, got 'a'``).

Booleans are never numbers here, although Python counts ``True`` as ``1``. Numpy scalars are numbers
(numpy registers them as :class:`numbers.Real`). The module imports numpy only inside the checks of
arrays, so the CLI's ``--help`` may import it; it imports nothing of the package but :mod:`errors`
and :mod:`limits`, so any module of the core may use it.
"""

from __future__ import annotations

import math
import numbers
import re
from typing import TYPE_CHECKING, Any

from . import limits
from .errors import InputError, excerpt, one_line

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

#: Default tolerance on ``| |q| - 1 |`` for unit quaternions.
QUATERNION_NORM_TOL = 1e-3
#: Largest integer :func:`as_int` accepts (floats are exact up to 2**53).
MAX_EXACT_INT = 2**53


# ---------------------------------------------------------------------- objects
def expect_object(data: Any, where: str, expected: str = "an object") -> dict[Any, Any]:
    """``data`` itself when it is a mapping (a JSON object); else one line naming ``where`` and what was ``expected``."""
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected {expected}, got {type(data).__name__}")
    return data


def expect_list(data: Any, where: str) -> list[Any]:
    """``data`` itself when it is a list (a JSON array); else one line naming ``where``."""
    if not isinstance(data, list):
        raise InputError(f"{where}: expected a list, got {type(data).__name__}")
    return data


def reject_unknown(data: dict[str, Any], allowed: set[str], where: str) -> None:
    """Refuse a key of ``data`` outside ``allowed``, naming the first one (in a stable order)."""
    unknown = sorted(set(data) - allowed, key=excerpt)  # YAML keys may be numbers or None, not only text
    if unknown:
        key = unknown[0]
        name = one_line(key, limits.EXCERPT_CHARS) if isinstance(key, str) else excerpt(key)  # keep the message one line
        path = f"{where}.{name}" if where else name
        raise InputError(f"{path}: unknown field, expected one of {sorted(allowed)}")


# ---------------------------------------------------------------------- numbers
def is_real(v: Any) -> bool:
    """A real number (Python or numpy), not a bool.

    Examples
    --------
    >>> is_real(1.5), is_real(True), is_real("1")
    (True, False, False)
    """
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def is_int(v: Any) -> bool:
    """An integer (Python or numpy), not a bool.

    Examples
    --------
    >>> is_int(3), is_int(3.0), is_int(False)
    (True, False, False)
    """
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


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
    if not is_real(value):
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


def as_float(value: Any, where: str) -> float:
    """A finite float from a number (not a bool) or a numeric text (a cell of a table).

    Examples
    --------
    >>> as_float(" 2.5 ", "row 3: score")
    2.5
    """
    if not isinstance(value, str):
        return finite_number(value, where)
    try:
        out = float(value.strip())
    except ValueError:
        raise InputError(f"{where}: expected a number, got {excerpt(value)}") from None
    if not math.isfinite(out):
        raise InputError(f"{where}: got {out}, expected a finite number")
    return out


def as_int(value: Any, where: str, minimum: int | None = None) -> int:
    """An integer from an int, an integral float or a numeric text; at least ``minimum`` when given."""
    x = as_float(value, where)
    if not x.is_integer() or abs(x) > MAX_EXACT_INT:
        raise InputError(f"{where}: expected an integer, got {excerpt(value)}")
    out = int(x)
    if minimum is not None and out < minimum:
        raise InputError(f"{where}: got {out}, expected an integer >= {minimum}")
    return out


# ---------------------------------------------------------------------- vectors and arrays
def vector(value: Any, n: int, where: str) -> NDArray[np.float64]:
    """``n`` finite numbers from a list, a tuple or a 1-D array, shape (n,); each element checked by :func:`finite_number`."""
    import numpy as np

    if isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise InputError(f"{where}: expected a list of {n} numbers, got {excerpt(value)}")
    if len(value) != n:
        raise InputError(f"{where}: expected {n} numbers, got {len(value)}")
    return np.array([finite_number(v, f"{where}[{i}]") for i, v in enumerate(value)])


def first_non_number(value: Any) -> Any:
    """The first element of nested lists, tuples or arrays that is not a number (text, bool, None), else None.

    An array counts as one element: numbers when its dtype is integer or float.
    """
    import numpy as np

    stack = [value]
    while stack:
        v = stack.pop()
        if isinstance(v, np.ndarray):
            if v.dtype.kind not in "iuf":
                return v
        elif isinstance(v, (list, tuple)):
            stack.extend(reversed(v))
        elif not is_real(v):
            return v
    return None


def finite_array(value: ArrayLike, shape: tuple[int, ...], where: str) -> NDArray[np.float64]:
    """A finite float array of exactly ``shape`` from nested lists of numbers (text, booleans and None refused)."""
    if first_non_number(value) is not None:
        got = f"an array of {value.dtype}" if hasattr(value, "dtype") else excerpt(value)
        raise InputError(f"{where}: expected numbers with shape {list(shape)}, got {got}")
    arr = _float_array(value, where, f"numbers with shape {list(shape)}")
    if arr.shape != shape:
        raise InputError(f"{where}: expected shape {list(shape)}, got {list(arr.shape)}")
    return _all_finite(arr, where)


def as_array(value: Any, where: str, shape: tuple[int, ...] | None = None, size: int | None = None) -> NDArray[np.float64]:
    """A finite float array from nested lists (or an array), optionally of a fixed ``shape`` or ``size``.

    Unlike :func:`finite_array`, a flat list of the right length is reshaped to ``shape`` (calibration
    files write matrices row by row).
    """
    if isinstance(value, (str, bytes, dict)) or value is None or isinstance(value, bool):
        raise InputError(f"{where}: expected a list of numbers, got {excerpt(value)}")
    bad = first_non_number(value)
    if bad is not None:
        raise InputError(f"{where}: expected a list of numbers, got {excerpt(bad)} in {excerpt(value)}")
    arr = _float_array(value, where, "a list of numbers")
    if shape is not None and arr.shape != shape:
        if arr.size == math.prod(shape) and arr.ndim <= 1:
            arr = arr.reshape(shape)
        else:
            raise InputError(f"{where}: expected shape {list(shape)}, got {list(arr.shape)}")
    if size is not None and arr.size != size:
        raise InputError(f"{where}: expected {size} numbers, got {arr.size}")
    return _all_finite(arr, where)


def _float_array(value: Any, where: str, expected: str) -> NDArray[np.float64]:
    """``value`` (nested lists of numbers, checked by the caller) as a float array; ragged lists and huge integers refused."""
    import numpy as np

    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: expected {expected}, got {excerpt(value)}") from None
    except OverflowError:
        raise InputError(f"{where}: got {excerpt(value)}, a number too large") from None
    return arr


def _all_finite(arr: NDArray[np.float64], where: str) -> NDArray[np.float64]:
    """``arr`` itself when every entry is finite; else one line naming ``where``."""
    import numpy as np

    if not np.all(np.isfinite(arr)):
        raise InputError(f"{where}: contains NaN or infinity")
    return arr


def check_position(p: NDArray[np.float64], where: str) -> None:
    """Refuse a position with a coordinate beyond :data:`~monovisual3d.limits.MAX_ABS_POSITION_M` metres."""
    import numpy as np

    big = float(np.max(np.abs(p)))
    if not big <= limits.MAX_ABS_POSITION_M:
        raise InputError(f"{where}: coordinate {big:.3g} m, beyond the {limits.MAX_ABS_POSITION_M:g} m accepted (wrong units?)")


def check_quaternion_xyzw(
    q: ArrayLike, *, where: str = "quaternion_xyzw", tol: float = QUATERNION_NORM_TOL
) -> NDArray[np.float64]:
    """Validate a unit quaternion in (x, y, z, w) order and return it normalised.

    Parameters
    ----------
    q : array_like, shape (4,)
        Quaternion, (x, y, z, w).
    where : str
        Name used in the error message (e.g. ``views[3].pose.quaternion_xyzw``).
    tol : float
        Accepted deviation of the norm from 1.

    Returns
    -------
    q : ndarray, shape (4,), float64
        The quaternion scaled to unit norm.

    Examples
    --------
    >>> check_quaternion_xyzw([0, 0, 0, 1])
    array([0., 0., 0., 1.])
    """
    import numpy as np

    arr = finite_array(q, (4,), where)
    with np.errstate(over="ignore"):  # huge entries: norm inf, reported below
        norm = float(np.linalg.norm(arr))
    if not abs(norm - 1.0) <= tol:
        raise InputError(f"{where}: norm {norm:.4g}, expected 1 (order is x, y, z, w)")
    return arr / norm


# ---------------------------------------------------------------------- byte sizes
def parse_bytes(value: Any, name: str = "max_memory") -> int:
    """A memory size in bytes from a number or a string such as ``"2GiB"``, ``"512 MB"``, ``"1.5g"``.

    At least :data:`~monovisual3d.limits.MIN_MAX_MEMORY`; capped at :data:`~monovisual3d.limits.MAX_PARSED_BYTES`.

    Examples
    --------
    >>> parse_bytes("2GiB"), parse_bytes(1e9), parse_bytes("512 mb")
    (2147483648, 1000000000, 512000000)
    """
    if isinstance(value, str):
        m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([a-zA-Z]*)\s*", value)
        if m is None or m.group(2).lower() not in limits.BYTE_UNITS:
            raise InputError(f"{name}: got {value[:40]!r}, expected a size in bytes such as 2GiB, 512MiB or 1e9")
        number = float(m.group(1)) * limits.BYTE_UNITS[m.group(2).lower()]
    elif is_real(value):
        number = float(value)
    else:
        raise InputError(f"{name}: got {type(value).__name__}, expected a size in bytes such as 2GiB or 1e9")
    if not (math.isfinite(number) and number >= limits.MIN_MAX_MEMORY):
        raise InputError(f"{name}: got {value!r}, expected at least {limits.MIN_MAX_MEMORY // 1024**2} MiB")
    return int(min(number, limits.MAX_PARSED_BYTES))


def format_bytes(n: float) -> str:
    """``1.5 GiB``-style text of a byte count.

    Examples
    --------
    >>> format_bytes(1.5 * 1024**3), format_bytes(512)
    ('1.5 GiB', '512 B')
    """
    for unit, size in (("GiB", 1024**3), ("MiB", 1024**2), ("KiB", 1024)):
        if n >= size:
            v = n / size
            return f"{v:.1f} {unit}" if v < 1e5 else f"{v:.4g} {unit}"
    return f"{int(n)} B"
