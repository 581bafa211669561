"""The ``quadric`` method: LfD's closed-form dual-quadric estimate (Rubino, Crocco, Del Bue, TPAMI 2017).

The field's standard baseline for localising objects of any shape from detection boxes with a known
association: each box becomes its inscribed ellipse, and one linear system per object gives the
ellipsoid whose outlines best fit those ellipses (:mod:`.dual`). It needs the association: the
detections' ``track`` ids when given, otherwise the one the ``bayes`` method finds (:mod:`.localizer`).

- :mod:`.config` — :class:`QuadricConfig`;
- :mod:`.dual` — the dual-quadric solve: inscribed conics, the linear system, its preconditioning (the
  ellipsoid of a dual quadric is geometry: :func:`monovisual3d.geometry.quadric.ellipsoid_from_dual_quadric`);
- :mod:`.localizer` — :func:`run`: association, one solve per object, the result.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

#: Public name -> submodule; imported on first use so reading the config does not load numpy.
_LAZY = {"QuadricConfig": "config", "run": "localizer"}

__all__ = ["QuadricConfig", "run"]

if TYPE_CHECKING:  # pragma: no cover
    from .config import QuadricConfig
    from .localizer import run


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
