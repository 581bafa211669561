"""MuJoCo path with ellipsoid fruit: MJCF ellipsoid geoms whose rendered boxes match the conic boxes."""

from __future__ import annotations

import importlib.util
import os

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d import Camera
from monovisual3d.sim.mujoco_render import mjcf_from_scene, scene_lowest_z, select_gl_backend
from monovisual3d.sim.raycast import render
from monovisual3d.sim.scene import Scene
from monovisual3d.sim.scenes import shapes_scene
from monovisual3d.sim.viewpoints import paper_poses

if "MUJOCO_GL" not in os.environ and importlib.util.find_spec("mujoco") is not None:
    try:
        select_gl_backend()
    except RuntimeError as exc:  # no OpenGL at all
        pytest.skip(str(exc), allow_module_level=True)
mujoco = pytest.importorskip("mujoco")

from monovisual3d.sim.mujoco_render import MujocoRenderer, RenderConfig  # noqa: E402
from monovisual3d.vision import boxes_from_label_image  # noqa: E402

CAMERA = Camera.from_hfov(320, 240, 69.0)


def test_ellipsoid_geoms_carry_semi_axes_and_orientation() -> None:
    scene = shapes_scene("mixed", rng=2, camera=CAMERA)
    model = mujoco.MjModel.from_xml_string(mjcf_from_scene(scene, CAMERA))
    for i, f in enumerate(scene.fruits):
        g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"fruit_{i}")
        assert model.geom_type[g] == mujoco.mjtGeom.mjGEOM_ELLIPSOID
        assert_allclose(model.geom_size[g], f.semi_axes, rtol=1e-6)
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, model.geom_quat[g])
        assert_allclose(R.reshape(3, 3), f.rotation, atol=1e-6)
    lowest = min(f.centre[2] - np.sqrt(np.sum((f.rotation[2] * f.semi_axes) ** 2)) for f in scene.fruits)
    assert_allclose(scene_lowest_z(scene), lowest)


def test_rendered_ellipsoid_boxes_match_the_ray_cast_camera() -> None:
    """MuJoCo's visible boxes equal the ray-cast camera's (itself tested against the conic box)."""
    scene: Scene = shapes_scene("mixed", rng=4, camera=CAMERA)
    errors = []
    with MujocoRenderer(scene, CAMERA, RenderConfig(ground=False)) as renderer:
        for T in paper_poses():
            boxes = boxes_from_label_image(renderer.render(T).labels, len(scene.fruits))[0]
            exact = render(scene, CAMERA, T, supersample=4).boxes_xyxy  # visible parts (fruit may overlap)
            errors.append(np.abs(boxes - exact))
    errors = np.array(errors)
    # pixel centres decide coverage (0.5 px) plus the tessellation of the surface
    assert errors.max() <= 1.0, errors.max()
    assert errors.mean() <= 0.35
