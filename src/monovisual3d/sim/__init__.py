"""Simulation: scenes, a bounding-box camera, viewpoints and noise (numpy only).

The photorealistic MuJoCo path lives in :mod:`monovisual3d.sim.mujoco_render`
(extra ``[sim]``).
"""

from __future__ import annotations

from .scene import Leaf, Scene, Sphere, Stem

__all__ = ["Leaf", "Scene", "Sphere", "Stem"]
