"""Fixtures of the engine tests: the paper scene's views with exact boxes, cameras with each distortion model."""

from __future__ import annotations

import numpy as np
import pytest

from monovisual3d.camera import Camera
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.grid import VoxelGrid
from monovisual3d.session import Detection, View
from monovisual3d.sim.scenes import paper_scene
from monovisual3d.sim.viewpoints import paper_poses

#: Distortion models and coefficients tested; "strong" folds over inside the grid's field of view.
DISTORTIONS = {
    "none": ("none", ()),
    "plumb_bob": ("plumb_bob", (-0.12, 0.05, 0.001, -0.002, 0.01)),
    "rational": ("rational_polynomial", (0.3, -0.1, 0.001, 0.0015, 0.02, 0.35, -0.05, 0.01)),
    "equidistant": ("equidistant", (0.05, -0.02, 0.004, -0.001)),
    "strong": ("plumb_bob", (-0.45, 0.08, 0.0, 0.0, 0.0)),
}


def make_camera(name: str) -> Camera:
    model, coeffs = DISTORTIONS[name]
    base = Camera.from_hfov(640, 480, 69.0)
    return Camera(640, 480, base.fx, base.fy, base.cx - 3.0, base.cy + 2.0, model, coeffs)


def scene_views(camera: Camera, n_views: int = 3) -> list[View]:
    """The paper's three poses (and more around them) with the six spheres' exact boxes."""
    scene = paper_scene()
    poses = list(paper_poses())
    rng = np.random.default_rng(7)
    while len(poses) < n_views:
        T = poses[len(poses) % 3].copy()
        T[:3, 3] += rng.normal(scale=0.03, size=3)
        poses.append(T)
    views = []
    for T in poses[:n_views]:
        boxes = sphere_bbox(camera, T, scene.centres, scene.radii)
        boxes = boxes[np.all(np.isfinite(boxes), axis=1)]
        views.append(View(T, tuple(Detection(b) for b in boxes)))
    return views


def paper_cube(views: list[View], edge: int) -> VoxelGrid:
    """The paper's 1.2 m cube in front of the first view with ``edge**3`` cells."""
    return VoxelGrid.in_front_of_camera(views[0].T_base_optical, 1.2 / edge, 0.6)


@pytest.fixture(params=sorted(DISTORTIONS))
def distortion(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture
def camera() -> Camera:
    return make_camera("none")


@pytest.fixture
def views(camera: Camera) -> list[View]:
    return scene_views(camera)
