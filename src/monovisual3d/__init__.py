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

from .camera import Camera
from .errors import InputError, InputWarning
from .filter import HistogramFilter, PaperConfig
from .grid import VoxelGrid
from .localize import METHODS, localize
from .metrics import evaluate
from .result import DetectedObject, Result
from .session import Detection, Session, View, Workspace, load_session

__version__ = "0.1.0"

__all__ = [
    "Camera",
    "Detection",
    "DetectedObject",
    "HistogramFilter",
    "InputError",
    "InputWarning",
    "METHODS",
    "PaperConfig",
    "Result",
    "Session",
    "View",
    "VoxelGrid",
    "Workspace",
    "evaluate",
    "load_session",
    "localize",
]
