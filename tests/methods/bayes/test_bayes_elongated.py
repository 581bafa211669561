"""Tests of the ``bayes`` method's upright-spheroid hypotheses (issue 20): tall objects found and associated."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.camera import Camera
from monovisual3d.errors import InputError
from monovisual3d.frames import invert_transform, look_at, transform_points
from monovisual3d.geometry.ellipsoid import Ellipsoid, ellipsoid_bbox_optical, rotation_upright
from monovisual3d.geometry.sphere import predict_sphere_boxes
from monovisual3d.geometry.spheroid import predict_spheroid_boxes
from monovisual3d.methods.bayes import BayesConfig, run
from monovisual3d.methods.bayes._kernels import score_hypotheses
from monovisual3d.methods.bayes.likelihood import SensorModel, view_scores
from monovisual3d.session import Workspace
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scene import EllipsoidFruit, Scene
from monovisual3d.sim.simulate import simulate

CAM = Camera.from_hfov(1280, 720, 69.0)
TARGET = np.array([0.6, 0.0, 0.3])
UP = np.array([0.0, 0.0, 1.0])
#: A 40 cm cube around the objects (keeps the tests quick; the search is the same).
WS = Workspace(TARGET - 0.2, TARGET + 0.2)
#: The upright container of the issue: 5 x 5 x 12 cm.
CONTAINER = (0.025, 0.025, 0.06)
DISTORTIONS = [("none", ()), ("plumb_bob", (-0.1, 0.02, 0.001, -0.001, 0.003)), ("equidistant", (0.01, -0.02, 0.003, 0.0))]


def three_views(rng, distance=0.6):
    """Three views 0.6 m from TARGET spread over 120 degrees, from 0-30 degrees above, aimed within 2 cm of it."""
    elevation = np.radians(rng.uniform(0.0, 30.0))
    out = []
    for az in np.radians([-60.0, 0.0, 60.0]):
        p = TARGET + distance * np.array([-np.cos(elevation) * np.cos(az), np.cos(elevation) * np.sin(az), np.sin(elevation)])
        out.append(look_at(p, TARGET + rng.uniform(-0.02, 0.02, 3)))
    return np.array(out)


def containers(centres):
    return Scene(
        tuple(EllipsoidFruit.from_ellipsoid(Ellipsoid.from_rotation(c, CONTAINER, rotation_upright(0.3))) for c in centres)
    )


def localise(scene, poses, rng):
    session, truth = simulate(scene, CAM, poses, noise=NoiseModel(box_sigma=0.02), rng=rng, workspace=WS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return run(session, BayesConfig()), truth


def test_spheroid_boxes_are_the_exact_ellipsoid_boxes_and_spheres_the_sphere_model():
    rng = np.random.default_rng(0)
    up = rng.normal(size=3)
    up /= np.linalg.norm(up)
    e1 = np.cross(up, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    R = np.stack([e1, np.cross(up, e1), up], axis=1)
    p = TARGET[None] + rng.uniform(-0.2, 0.2, (20, 3))
    boxes, visible = predict_spheroid_boxes(CAM, p, [0.02, 0.03, 0.025], [0.05, 0.03, 0.01], up)
    for i in range(len(p)):
        assert_allclose(boxes[i, 0], ellipsoid_bbox_optical(CAM, p[i], [0.02, 0.02, 0.05], R, clip=False), atol=1e-6)
        assert_allclose(boxes[i, 2], ellipsoid_bbox_optical(CAM, p[i], [0.025, 0.025, 0.01], R, clip=False), atol=1e-6)
    spheres, sphere_visible = predict_sphere_boxes(CAM, p, np.array([0.03]))
    assert_allclose(boxes[:, 1], spheres[:, 0], rtol=0, atol=0)
    assert np.array_equal(visible[:, 1], sphere_visible[:, 0])
    behind, vis = predict_spheroid_boxes(
        CAM, np.array([[0.0, 0.0, 0.03]]), [0.02], [0.05], [0.0, 0.0, 1.0]
    )  # reaches behind the camera
    assert np.all(np.isnan(behind)) and not vis.any()


@pytest.mark.parametrize("distortion", DISTORTIONS)
def test_numba_kernel_matches_numpy_reference_for_spheroid_bins(distortion):
    cam = Camera(640, 480, 480, 470, 322, 238, *distortion)
    rng = np.random.default_rng(2)
    poses = three_views(rng, 0.5)
    T_ob = [invert_transform(T) for T in poses]
    truth = TARGET + rng.uniform(-0.1, 0.1, (3, 3))
    boxes = []
    for T in T_ob:
        b = [ellipsoid_bbox_optical(cam, transform_points(T, c[None])[0], CONTAINER, T[:3, :3], clip=False) for c in truth]
        boxes.append(np.array(b) + rng.normal(0, 2.0, (3, 4)))
    boxes[0] = np.vstack([boxes[0], [0, 10, 40, 80]])  # a border-touching box
    avail = [np.ones(len(b), bool) for b in boxes]
    avail[1][0] = False
    centres = TARGET + rng.uniform(-0.15, 0.15, (400, 3))
    radii = np.array([0.01, 0.02, 0.03, 0.02, 0.025, 0.04])
    semi_up = np.array([0.01, 0.02, 0.03, 0.04, 0.06, 0.02])  # spheres, prolate and oblate spheroids
    model = SensorModel()
    blur = 0.004
    total, n_assoc, assoc = score_hypotheses(cam, T_ob, boxes, avail, centres, radii, model, blur, 0.0, None, semi_up, UP)
    ref_total, ref_n = np.zeros_like(total), np.zeros_like(n_assoc)
    for v, (T, b, a) in enumerate(zip(T_ob, boxes, avail)):
        p_opt = transform_points(T, centres)
        pred, vis = predict_spheroid_boxes(cam, p_opt, radii, semi_up, T[:3, :3] @ UP)
        extra = max(cam.fx, cam.fy) * blur / np.maximum(p_opt[:, 2:3], 1e-6)
        llr, a_ref = view_scores(pred, vis, b, a, model, cam.width, cam.height, extra)
        ref_total += llr
        ref_n += a_ref >= 0
        assert_allclose(assoc[v], a_ref)
    assert_allclose(total, ref_total, rtol=1e-9, atol=1e-9)
    assert_allclose(n_assoc, ref_n)
    assert np.any(ref_n >= 2)


@pytest.mark.parametrize("distortion", DISTORTIONS)
def test_compiled_spheroid_box_residuals_match_the_numpy_reference(distortion):
    from monovisual3d.methods.bayes.refine import Observation, _BoxResiduals

    cam = Camera(640, 480, 480, 470, 322, 238, *distortion)
    rng = np.random.default_rng(8)
    poses = three_views(rng, 0.5)
    obs = []
    for i, T in enumerate(poses):
        b = np.array([280.0, 150.0, 360.0, 330.0]) + rng.normal(0, 2.0, 4)
        if i == 2:
            b[2] = 640.0  # an edge at the image border (censored)
        obs.append(Observation(invert_transform(T), b, None, 0.4 * i))
    f = _BoxResiduals(cam, obs, SensorModel(), UP)
    centres = TARGET + rng.normal(0, 0.03, (40, 3))
    centres[0] = poses[0][:3, 3]  # at a camera: no valid box there
    radii, semi_up = rng.uniform(0.01, 0.04, 40), rng.uniform(0.01, 0.08, 40)
    semi_up[1] = radii[1]  # a sphere
    fused, ref = f.batch(centres, radii, semi_up), f.batch_numpy(centres, radii, semi_up)
    assert fused.shape == (40, 12)
    assert_allclose(fused, ref, rtol=1e-9, atol=1e-9)
    assert np.all(fused[0, :4] == 1e3)


def test_elongations_option_is_checked_and_builds_the_bins():
    cfg = BayesConfig(elongations="2, 1")
    assert cfg.elongations == (1.0, 2.0)
    across, along = cfg.hypothesis_bins
    assert_allclose(across[: cfg.n_radii], cfg.radii)
    assert_allclose(along[: cfg.n_radii], cfg.radii)
    assert_allclose(along[cfg.n_radii :], 2 * across[cfg.n_radii :])
    assert along.max() <= cfg.semi_axis_range[1] + 1e-12
    assert len(BayesConfig(elongations=(1,)).hypothesis_bins[0]) == cfg.n_radii
    for bad in ("0.5", "1,x", "", (True,)):
        with pytest.raises(InputError, match="elongations: got .*expected numbers >= 1"):
            BayesConfig(elongations=bad)


def test_single_upright_container_near_the_axis_is_found_in_every_seed():
    """5 x 5 x 12 cm, three views over 120 degrees at 0.6 m, 1280 x 720, boxes from the simulator (2 % noise)."""
    for seed in range(20):
        rng = np.random.default_rng(1000 + seed)
        centre = TARGET + rng.uniform(-0.02, 0.02, 3)
        result, _ = localise(containers([centre]), three_views(rng), rng)
        assert len(result.objects) == 1, f"seed {seed}: {len(result.objects)} objects"
        assert np.linalg.norm(result.objects[0].position - centre) < 0.01, f"seed {seed}"


def test_two_containers_with_overlapping_boxes_keep_their_own_boxes_in_every_seed():
    """Two containers 6 cm apart, side by side as the cameras see them, so their boxes overlap."""
    overlapping_views = 0
    for seed in range(20):
        rng = np.random.default_rng(2000 + seed)
        side = np.array([0.0, 1.0, 0.0]) + rng.uniform(-0.3, 0.3, 3) * [1, 0, 0]
        side /= np.linalg.norm(side)
        centres = [TARGET + 0.03 * side, TARGET - 0.03 * side]
        result, truth = localise(containers(centres), three_views(rng), rng)
        assert len(result.objects) == 2, f"seed {seed}: {len(result.objects)} objects"
        fruit_of = [v["detection_fruit"] for v in truth["views"]]
        for obj in result.objects:
            sources = {fruit_of[v][j] for v, j in obj.associations.items()}
            assert len(sources) == 1 and len(obj.associations) == 3, f"seed {seed}: boxes of fruit {sources} in one object"
            assert np.linalg.norm(obj.position - centres[sources.pop()]) < 0.01, f"seed {seed}"
        for v in truth["views"]:
            a, b = (np.asarray(x) for x in v["visible_bbox_xyxy"])
            overlapping_views += bool(min(a[2], b[2]) > max(a[0], b[0]) and min(a[3], b[3]) > max(a[1], b[1]))
    assert overlapping_views >= 40  # most views see the two boxes overlap
