"""Simulation: scenes, a bounding-box camera, viewpoints and noise (numpy only).

- :mod:`~monovisual3d.sim.scene`: the Scene/Sphere/EllipsoidFruit/Leaf/Stem dataclasses and their JSON;
- :mod:`~monovisual3d.sim.scenes`: built-in scenes (paper, greenhouse, random, peppers, cucumbers, apples, mixed);
- :mod:`~monovisual3d.sim.raycast`: the bounding-box camera (exact ray casting, visible boxes);
- :mod:`~monovisual3d.sim.viewpoints`: the paper's poses, permutations, rings, hemispheres, arcs, rows;
- :mod:`~monovisual3d.sim.motion`: views as frames along a path, a time offset, the pose stream;
- :mod:`~monovisual3d.sim.noise`: the paper's box noise, missed detections, false positives, pose error;
- :mod:`~monovisual3d.sim.simulate`: sessions and ground truth from all of the above;
- :mod:`~monovisual3d.sim.containers`, :mod:`~monovisual3d.sim.tabletop`: the scenes of the experiments (containers on
  a robot arm's bench, a table top of lying boxes and bottles), with the exact boxes of solids.
- :mod:`~monovisual3d.sim.mistakes`: the integration mistakes a robot integrator makes, made on a session.

The photorealistic MuJoCo path lives in :mod:`monovisual3d.sim.mujoco_render`
(extra ``[sim]``).
"""

from __future__ import annotations

from .noise import NoiseModel
from .raycast import Rendering, render
from .scene import EllipsoidFruit, Leaf, Scene, Sphere, Stem
from .scenes import (
    default_camera,
    fruit_of_kind,
    greenhouse_scene,
    paper_scene,
    random_scene,
    scene_by_name,
    scene_target,
    shapes_scene,
)
from .simulate import simulate, write_simulation
from .viewpoints import arc_poses, hemisphere_poses, paper_poses, pose_permutations, poses_by_name, ring_poses

__all__ = [
    "EllipsoidFruit",
    "Leaf",
    "NoiseModel",
    "Rendering",
    "Scene",
    "Sphere",
    "Stem",
    "arc_poses",
    "default_camera",
    "fruit_of_kind",
    "greenhouse_scene",
    "hemisphere_poses",
    "paper_poses",
    "paper_scene",
    "pose_permutations",
    "poses_by_name",
    "random_scene",
    "render",
    "ring_poses",
    "scene_by_name",
    "scene_target",
    "shapes_scene",
    "simulate",
    "write_simulation",
]
