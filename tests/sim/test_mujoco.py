"""MuJoCo photorealistic path: camera conversion, rendering, colour detector, pixels -> boxes -> 3D.

MuJoCo fixes its OpenGL backend when it is first imported, so this module sets
``MUJOCO_GL`` first: the value already in the environment, else the first of
``egl`` and ``osmesa`` that works (:func:`select_gl_backend`).
"""

from __future__ import annotations

import importlib.util
import json
import os
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d import Camera, InputError, evaluate, load_session, localize
from monovisual3d.frames import look_at
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.sim.mujoco_render import (
    T_base_mjcam_from_T_base_optical,
    frustum_from_camera,
    mjcf_from_scene,
    select_gl_backend,
)
from monovisual3d.sim.scene import Leaf, Scene, Sphere, Stem

if "MUJOCO_GL" not in os.environ and importlib.util.find_spec("mujoco") is not None:
    try:
        select_gl_backend()
    except RuntimeError as exc:  # no OpenGL at all: say which packages are missing
        pytest.skip(str(exc), allow_module_level=True)
mujoco = pytest.importorskip("mujoco")
pytest.importorskip("cv2")

from monovisual3d.sim.mujoco_render import MujocoRenderer, RenderConfig, render_view  # noqa: E402
from monovisual3d.sim.photoreal import render_views  # noqa: E402
from monovisual3d.vision import boxes_from_label_image, detect_colour, match_boxes  # noqa: E402

#: Off-centre principal point and fx != fy: checks every intrinsic reaches the renderer.
CAMERA_ODD = Camera(320, 240, 290.0, 305.0, 149.3, 131.8)
CAMERA_HFOV = Camera.from_hfov(320, 240, 69.0)

CENTRES = np.array([[0.55, 0.0, 0.40], [0.58, 0.11, 0.46], [0.52, -0.10, 0.33]])
RADII = np.array([0.030, 0.036, 0.025])
TARGET = CENTRES.mean(axis=0)


def fruit_scene(occluders: tuple = ()) -> Scene:
    return Scene(tuple(Sphere(c, float(r)) for c, r in zip(CENTRES, RADII)), occluders, name="three_fruit")


def spread_poses(distance: float = 0.45) -> list[np.ndarray]:
    """Three views of the fruit: straight ahead, from the left and below, from the right and above."""
    directions = np.array([[-1.0, 0.0, 0.0], [-0.6, 0.6, -0.35], [-0.6, -0.55, 0.5]])
    return [look_at(TARGET + distance * d / np.linalg.norm(d), TARGET) for d in directions]


def random_poses(rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """Cameras 0.3-0.6 m from the fruit, in front of them, aimed near (not at) the cluster."""
    poses = []
    for _ in range(n):
        d = rng.normal(size=3) * [0.3, 1.0, 0.7] + [-1.5, 0.0, 0.0]
        d /= np.linalg.norm(d)
        aim = TARGET + rng.uniform(-0.05, 0.05, 3)
        poses.append(look_at(TARGET + rng.uniform(0.3, 0.6) * d, aim))
    return poses


def label_boxes(labels: np.ndarray) -> np.ndarray:
    return boxes_from_label_image(labels, len(CENTRES))[0]


@pytest.fixture(scope="module")
def renderer_odd():
    with MujocoRenderer(fruit_scene(), CAMERA_ODD) as r:
        yield r


# ---------------------------------------------------------------------- pure helpers


def test_mjcam_frame_looks_along_minus_z_with_y_up(rng: np.random.Generator) -> None:
    T = look_at(rng.normal(size=3), rng.normal(size=3) + 5.0)
    T_mj = T_base_mjcam_from_T_base_optical(T)
    assert_allclose(T_mj[:3, 0], T[:3, 0])  # x right in both
    assert_allclose(T_mj[:3, 1], -T[:3, 1])  # y up vs y down
    assert_allclose(T_mj[:3, 2], -T[:3, 2])  # MuJoCo looks along -z
    assert_allclose(T_mj[:3, 3], T[:3, 3])
    assert_allclose(T_base_mjcam_from_T_base_optical(T_mj), T, atol=1e-12)  # an involution


def test_frustum_reproduces_pinhole_projection(rng: np.random.Generator) -> None:
    near = 0.01
    f = frustum_from_camera(CAMERA_ODD, near)
    left, right = f["frustum_center"] - f["frustum_width"], f["frustum_center"] + f["frustum_width"]
    # A point on the near plane (MuJoCo frame: x right, y up, z = -near) lands on the pixel of the same optical ray.
    p_opt = np.column_stack([rng.uniform(-0.3, 0.3, 20), rng.uniform(-0.2, 0.2, 20), np.ones(20)])
    uv = CAMERA_ODD.project(p_opt)
    x_near, y_near = near * p_opt[:, 0], -near * p_opt[:, 1]
    u_gl = CAMERA_ODD.width * (x_near - left) / (right - left)
    v_gl = CAMERA_ODD.height * (f["frustum_top"] - y_near) / (f["frustum_top"] - f["frustum_bottom"])
    assert_allclose(np.column_stack([u_gl, v_gl]), uv, atol=1e-9)
    centred = frustum_from_camera(CAMERA_HFOV, near)
    assert centred["frustum_center"] == 0.0 and centred["frustum_top"] == -centred["frustum_bottom"]
    with pytest.raises(InputError, match="near"):
        frustum_from_camera(CAMERA_ODD, 0.0)


def test_mjcf_compiles_with_named_geoms_and_camera() -> None:
    scene = fruit_scene(
        (
            Leaf(np.array([0.45, 0.0, 0.5]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]), (0.05, 0.03)),
            Stem(np.array([0.55, 0.0, 0.4]), np.array([0.55, 0.0, 0.7]), 0.004),
        )
    )
    model = mujoco.MjModel.from_xml_string(mjcf_from_scene(scene, CAMERA_ODD))
    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) for i in range(model.ngeom)}
    assert names == {"ground", "fruit_0", "fruit_1", "fruit_2", "leaf_0", "stem_1"}
    assert model.ncam == 1 and model.nmocap == 1
    assert list(model.cam_resolution[0]) == [320, 240]
    fruit = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "fruit_1")
    assert_allclose(model.geom_size[fruit, 0], RADII[1])
    assert_allclose(model.geom_pos[fruit], CENTRES[1])


def test_distorted_camera_is_refused() -> None:
    cam = Camera(320, 240, 300.0, 300.0, 160.0, 120.0, "plumb_bob", (-0.2, 0.05, 0.0, 0.0))
    with pytest.raises(InputError, match="distortion"):
        mjcf_from_scene(fruit_scene(), cam)


def test_select_gl_backend_falls_back_to_osmesa(monkeypatch: pytest.MonkeyPatch) -> None:
    import monovisual3d.sim.mujoco_render as mr

    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.delitem(sys.modules, "mujoco")  # pretend mujoco is not imported yet
    monkeypatch.setattr(mr, "gl_backend_works", lambda backend: backend == "osmesa")
    assert mr.select_gl_backend() == "osmesa"
    assert os.environ["MUJOCO_GL"] == "osmesa"
    monkeypatch.delenv("MUJOCO_GL")
    monkeypatch.setattr(mr, "gl_backend_works", lambda backend: False)
    with pytest.raises(RuntimeError, match="libosmesa6"):
        mr.select_gl_backend()
    monkeypatch.setenv("MUJOCO_GL", "egl")
    assert mr.select_gl_backend() == "egl"  # an explicit choice is kept


# ---------------------------------------------------------------------- rendering


@pytest.mark.parametrize("camera", [CAMERA_ODD, CAMERA_HFOV], ids=["offcentre", "hfov69"])
def test_segmentation_box_matches_analytic_sphere_box(camera: Camera, rng: np.random.Generator) -> None:
    """The rendered silhouette box equals the exact one: intrinsics and pose conversion are right."""
    errors = []
    with MujocoRenderer(fruit_scene(), camera, RenderConfig(ground=False)) as renderer:
        for T in random_poses(rng, 6):
            view = renderer.render(T)
            boxes = label_boxes(view.labels)
            exact = sphere_bbox(camera, T, CENTRES, RADII)
            for k in range(len(CENTRES)):
                others = [j for j in range(len(CENTRES)) if j != k]
                ious = [np.nan_to_num(_iou(exact[k], exact[j])) for j in others]
                if max(ious) > 0 or not np.all(np.isfinite(exact[k])):
                    continue  # overlapping silhouettes: the visible box may be smaller
                errors.append(np.abs(boxes[k] - exact[k]))
    errors = np.array(errors)
    assert len(errors) >= 10
    # Pixel centres decide coverage, so an edge is off by at most 0.5 px plus the tessellation of the sphere.
    assert errors.max() <= 1.0, errors.max()
    assert errors.mean() <= 0.35


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    from monovisual3d.vision import box_iou

    return float(box_iou(a, b))


def test_mjcf_intrinsics_alone_give_the_same_image(renderer_odd: MujocoRenderer) -> None:
    """The saved model.xml shows the same view in MuJoCo without our frustum override."""
    T = spread_poses()[1]
    ours = renderer_odd.render(T).labels
    plain = mujoco.Renderer(renderer_odd.model, CAMERA_ODD.height, CAMERA_ODD.width)
    try:
        plain.enable_segmentation_rendering()
        plain.update_scene(renderer_odd.data, camera="camera")
        seg = plain.render()
    finally:
        plain.close()
    geom = np.where(seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM), seg[..., 0], -1)
    fruit = np.where(geom >= 0, renderer_odd.geom_fruit[np.maximum(geom, 0)], -1)
    assert np.mean(fruit != ours) < 1e-3


def test_rgb_shows_red_fruit_and_labels_are_consistent(renderer_odd: MujocoRenderer) -> None:
    view = renderer_odd.render(spread_poses()[0])
    assert view.rgb.shape == (240, 320, 3) and view.rgb.dtype == np.uint8
    assert view.labels.shape == (240, 320) and view.labels.dtype == np.int32
    assert set(np.unique(view.labels)) == {-1, 0, 1, 2}
    rgb = view.rgb.astype(int)
    fruit = view.labels >= 0
    red = (rgb[..., 0] > rgb[..., 1] + 40) & (rgb[..., 0] > rgb[..., 2] + 40)
    assert red[fruit].mean() > 0.95
    assert red[~fruit].mean() < 0.01


def test_occluding_leaf_shrinks_or_hides_the_box() -> None:
    cam = CAMERA_HFOV
    T = look_at(TARGET - [0.45, 0.0, 0.0], TARGET)
    c0 = CENTRES[0]
    # A leaf just in front of fruit 0 covering its top half, one hiding fruit 2 completely.
    half_cover = Leaf(c0 - [0.05, 0.0, -0.03], np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]), (0.06, 0.03))
    full_cover = Leaf(CENTRES[2] - [0.05, 0.0, 0.0], np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]), (0.05, 0.05))
    view = render_view(fruit_scene((half_cover, full_cover)), cam, T, RenderConfig(ground=False))
    boxes = label_boxes(view.labels)
    exact = sphere_bbox(cam, T, CENTRES, RADII)
    assert np.all(np.isnan(boxes[2]))
    assert abs(boxes[0, 3] - exact[0, 3]) <= 1.0  # bottom edge still the silhouette's
    assert boxes[0, 1] > exact[0, 1] + 0.3 * (exact[0, 3] - exact[0, 1])  # top half hidden
    assert_allclose(boxes[1], exact[1], atol=1.0)  # untouched fruit


def test_colour_detector_agrees_with_segmentation(renderer_odd: MujocoRenderer) -> None:
    ious, edge_errors = [], []
    for T in spread_poses():
        view = renderer_odd.render(T)
        truth = label_boxes(view.labels)
        dets = np.stack([d.bbox_xyxy for d in detect_colour(view.rgb)])
        ia, ib, iou = match_boxes(truth, dets)
        assert len(dets) == len(CENTRES) and len(ia) == len(CENTRES)
        ious.extend(iou)
        edge_errors.extend(np.abs(truth[ia] - dets[ib]).ravel())
    assert min(ious) > 0.9, ious
    assert max(edge_errors) <= 2.0


# ---------------------------------------------------------------------- pipeline


def test_render_views_pixels_to_3d(tmp_path) -> None:
    """Render, detect by colour, localise with the paper's method: every fruit within 15 mm."""
    session, images = render_views(fruit_scene(), CAMERA_ODD, spread_poses(), tmp_path)
    assert len(session.views) == 3 and len(images) == 3
    assert all(len(v.detections) == 3 for v in session.views)
    workspace = {"min": (TARGET - 0.15).tolist(), "max": (TARGET + 0.15).tolist()}
    result = localize(session, method="paper", resolution=0.01, workspace=workspace)
    estimates = np.array([o.position for o in result.objects]).reshape(-1, 3)
    metrics = evaluate(estimates, CENTRES)
    assert metrics.n_estimates == 3 and metrics.true_positives == 3
    assert metrics.euclidean_max < 0.015, metrics

    # What was saved reloads and shows the same thing.
    loaded = load_session(tmp_path / "session.json")
    assert_allclose(loaded.views[1].boxes_xyxy, session.views[1].boxes_xyxy)
    assert_allclose(loaded.views[2].T_base_optical, session.views[2].T_base_optical, atol=1e-9)
    truth = json.loads((tmp_path / "truth.json").read_text())
    assert_allclose([o["position"] for o in truth["objects"]], CENTRES)
    for i in range(3):
        assert (tmp_path / loaded.views[i].image).is_file()
        rgb = pytest.importorskip("cv2").imread(str(tmp_path / f"images/view_{i:03d}_rgb.png"))[..., ::-1]
        np.testing.assert_array_equal(rgb, images[i].rgb)
        labels = pytest.importorskip("cv2").imread(str(tmp_path / f"images/view_{i:03d}_labels.png"), -1)
        np.testing.assert_array_equal(labels.astype(np.int32) - 1, images[i].labels)
        assert (tmp_path / f"images/view_{i:03d}_overlay.png").is_file()
    boxes_truth = json.loads((tmp_path / "boxes_truth.json").read_text())
    assert_allclose(boxes_truth["views"][0]["fruit"][1]["bbox_xyxy"], label_boxes(images[0].labels)[1])
    assert mujoco.MjModel.from_xml_path(str(tmp_path / "model.xml")).ngeom == 4


def test_render_views_without_output_dir_and_bad_poses() -> None:
    session, images = render_views(fruit_scene(), CAMERA_HFOV, spread_poses()[0])
    assert len(session.views) == 1 and session.views[0].image is None
    with pytest.raises(InputError, match=r"\(N, 4, 4\)"):
        render_views(fruit_scene(), CAMERA_HFOV, np.eye(3))
    with pytest.raises(InputError, match="poses\\[0\\]"):
        render_views(fruit_scene(), CAMERA_HFOV, [np.zeros((4, 4))])
