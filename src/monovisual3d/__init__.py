"""monovisual3d: 3D fruit localisation from 2D detections of one moving monocular camera.

Implements MonoVisual3DFilter (Magalhães et al., Robotica 2024) and improvements.

Quick use::

    import monovisual3d as mv3d
    session = mv3d.load_session("session.json")
    result = mv3d.localize(session, method="paper")
    for obj in result.objects:
        print(obj.position, obj.score)
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

#: Public name -> module that defines it. Imported on first use (PEP 562), so ``import monovisual3d``
#: costs almost nothing and the CLI starts fast; ``from monovisual3d import localize`` works as usual.
_LAZY = {
    "Camera": "camera",
    "Detection": "session",
    "DetectedObject": "result",
    "HistogramFilter": "methods.paper.filter",
    "InputError": "errors",
    "InputWarning": "errors",
    "METHODS": "methods",
    "PaperConfig": "methods.paper.config",
    "BayesConfig": "methods.bayes.config",
    "BayesLocalizer": "methods.bayes.localizer",
    "Result": "result",
    "Session": "session",
    "View": "session",
    "VoxelGrid": "grid",
    "Workspace": "session",
    "evaluate": "metrics",
    "load_session": "session.load",
    "localize": "api",
    "warmup": "api",
}

__all__ = sorted(_LAZY)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from .api import localize, warmup
    from .camera import Camera
    from .errors import InputError, InputWarning
    from .grid import VoxelGrid
    from .methods import METHODS
    from .methods.bayes.config import BayesConfig
    from .methods.bayes.localizer import BayesLocalizer
    from .methods.paper.config import PaperConfig
    from .methods.paper.filter import HistogramFilter
    from .metrics import evaluate
    from .result import DetectedObject, Result
    from .session import Detection, Session, View, Workspace
    from .session.load import load_session


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
