"""Lazy imports of optional dependencies with a helpful error."""

from __future__ import annotations

import importlib
from types import ModuleType

from .errors import MissingExtra


def require(module: str, extra: str) -> ModuleType:
    """Import ``module`` or raise :class:`~monovisual3d.errors.MissingExtra` (an ImportError) naming the extra that
    provides it.

    Examples
    --------
    >>> require("numpy", "core").__name__
    'numpy'
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise MissingExtra(f"{module} is needed for this feature: pip install 'monovisual3d[{extra}]'") from exc
