"""The shape stage's solids: an upright cylinder or cuboid (a container) is fitted with its exact boxes, so its centre
is not pulled down as an ellipsoid's is; ellipsoids and spheres keep their models."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

import monovisual3d as mv
import monovisual3d.geometry.fit as fit_module
import monovisual3d.methods.bayes.shapes as shapes_module
from monovisual3d.camera import Camera
from monovisual3d.cli import app
from monovisual3d.frames import look_at
from monovisual3d.geometry.ellipsoid import ellipsoid_bbox
from monovisual3d.geometry.fit import fit_ellipsoid_to_boxes, fit_shape_by_bic
from monovisual3d.geometry.orientation import rotation_upright
from monovisual3d.geometry.solids import cuboid_bbox, cylinder_bbox
from monovisual3d.methods.bayes import BayesConfig
from monovisual3d.methods.bayes.solid_choice import (
    SOLID_EVIDENCE_NATS,
    precise,
    size_residuals,
    solid_evidence,
    solid_if_clear,
    solid_may_win,
)
from monovisual3d.session import Detection, Session, View, Workspace
from monovisual3d.sim.noise import perturb_boxes, visible_part_boxes

CAM = Camera.from_hfov(1280, 720, 69.0)
TARGET = np.array([0.6, 0.0, 0.3])
#: A 5 x 5 x 12 cm container: radius (half-side) and half-height, metres.
R_M, H_M = 0.025, 0.06


def _poses(rng: np.random.Generator, n_views: int, elevation_deg: float) -> np.ndarray:
    """n_views poses over 120 degrees of azimuth, 0.5-0.7 m from the target, aimed within 2 cm of it."""
    e = np.radians(elevation_deg)
    out = []
    for az in np.radians(np.linspace(-60.0, 60.0, n_views)):
        p = TARGET + rng.uniform(0.5, 0.7) * np.array([-np.cos(e) * np.cos(az), np.cos(e) * np.sin(az), np.sin(e)])
        out.append(look_at(p, TARGET + rng.uniform(-0.02, 0.02, 3)))
    return np.array(out)


def _localize(poses: np.ndarray, boxes: np.ndarray, solids: bool = True) -> list:
    """The objects found from ``boxes``: one per view (K, 4) or several per view (K, N, 4)."""
    per_view = np.asarray(boxes, dtype=float).reshape(len(poses), -1, 4)
    views = tuple(View(T, tuple(Detection(b) for b in bs)) for T, bs in zip(poses, per_view))
    session = Session(CAM, views, Workspace(TARGET - 0.2, TARGET + 0.2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return mv.localize(session, solids=solids).objects


def _pair_error(poses: np.ndarray, boxes: np.ndarray, centres: np.ndarray) -> float:
    """The larger distance (metres) from each of the two ``centres`` to its nearest estimate; two objects must be found."""
    est = np.array([o.position for o in _localize(poses, boxes)])
    assert len(est) == 2
    d = np.linalg.norm(est[:, None] - centres[None], axis=2)
    return float(max(d[0].min(), d[1].min()))


def test_an_upright_cylinder_is_found_at_its_centre():
    # an upright spheroid fitted to these boxes lands 2.5-3 mm low (experiments/solid_shape_bias.py); the cylinder does not
    for seed in range(3):
        rng = np.random.default_rng(seed)
        poses = _poses(rng, 3, 25.0)
        objects = _localize(poses, cylinder_bbox(CAM, poses, TARGET, R_M, H_M, rotation_upright(0.0)))
        assert len(objects) == 1
        o = objects[0]
        assert o.extra.get("solid") == "cylinder" and o.shape == "spheroid"
        assert np.linalg.norm(o.position - TARGET) < 3e-4
        assert_allclose(o.semi_axes, [R_M, R_M, H_M], atol=5e-4)


def test_the_ellipsoid_fit_of_a_cylinder_is_biased_down():
    # the physical reason for the solids: seen from above, the top rim sticks out where an ellipsoid narrows
    rng = np.random.default_rng(4)
    poses = _poses(rng, 3, 25.0)
    boxes = cylinder_bbox(CAM, poses, TARGET, R_M, H_M, rotation_upright(0.0))
    spheroid = fit_ellipsoid_to_boxes(CAM, poses, boxes, shape="spheroid", box_sigma=0.02)
    assert -4e-3 < spheroid.ellipsoid.centre_base[2] - TARGET[2] < -1.5e-3


def test_a_yawed_cuboid_from_six_views_is_found_at_its_centre():
    rng = np.random.default_rng(5)
    poses = _poses(rng, 6, 20.0)
    objects = _localize(poses, cuboid_bbox(CAM, poses, TARGET, [R_M, R_M, H_M], rotation_upright(0.5)))
    assert len(objects) == 1
    o = objects[0]
    assert o.extra.get("solid") == "cuboid" and o.shape == "ellipsoid"
    assert np.linalg.norm(o.position - TARGET) < 3e-4


def test_a_flat_tray_from_three_views_is_a_cuboid_at_its_centre():
    # a 200 x 160 x 30 mm tray seen from its height: its boxes (250-450 px wide) are wide in every view, and their
    # widths follow a rectangle's, not an ellipse's; the spheroid misses them by about 10 px and lands 5-14 mm off,
    # which the sensor model's 5 % edge noise (15-25 px here) alone could not tell from the cuboid: before the solids
    # could win by their evidence, 6 of these 12 seeds came out as cuboids within 3 mm
    half_sides, found = [0.10, 0.08, 0.015], 0
    for seed in range(10, 22):
        rng = np.random.default_rng(seed)
        poses = _poses(rng, 3, 0.0)
        yaw = rng.uniform(0.0, np.pi)
        boxes = perturb_boxes(cuboid_bbox(CAM, poses, TARGET, half_sides, rotation_upright(yaw)), 0.002, rng)
        objects = _localize(poses, boxes)
        assert len(objects) == 1
        o = objects[0]
        found += o.extra.get("solid") == "cuboid" and np.linalg.norm(o.position - TARGET) < 3e-3
        if seed == 10:
            with_ellipsoids = _localize(poses, boxes, solids=False)[0]
            assert np.linalg.norm(with_ellipsoids.position - TARGET) > 5e-3  # the models of fruit cannot place it
    assert found >= 9


def test_a_flat_tray_seen_from_55_degrees_with_near_square_boxes_is_a_cuboid_at_its_centre():
    # from high above a 200 x 160 x 30 mm tray's boxes are about square, so nothing in their aspects sends it to the shape
    # fits; the search's sphere of 110-125 mm radius then stayed, 10-30 mm off in these seeds. An object that large is
    # fitted with every model however round its boxes look (shapes.LARGE_RADIUS_M), and the cuboid wins by its evidence
    for seed in range(6):
        rng = np.random.default_rng(seed)
        poses = _poses(rng, 3, 55.0)
        yaw = rng.uniform(0.0, np.pi)
        boxes = perturb_boxes(cuboid_bbox(CAM, poses, TARGET, [0.10, 0.08, 0.015], rotation_upright(yaw)), 0.005, rng)
        (o,) = _localize(poses, boxes)
        assert o.extra.get("solid") == "cuboid"
        assert np.linalg.norm(o.position - TARGET) < 4e-3
        if seed == 0:
            with pytest.MonkeyPatch.context() as mp:
                mp.setattr(shapes_module, "LARGE_RADIUS_M", np.inf)  # large objects' boxes judged as a fruit's
                (sphere,) = _localize(poses, boxes)
            assert "solid" not in sphere.extra and np.linalg.norm(sphere.position - TARGET) > 10e-3


def test_a_large_sphere_stays_a_sphere():
    # a melon-sized sphere (80 mm radius) is fitted with every model too, and none beats the sphere on its boxes
    for seed in range(3):
        rng = np.random.default_rng(seed)
        poses = _poses(rng, 3, 40.0)
        boxes = perturb_boxes(ellipsoid_bbox(CAM, poses, TARGET, [0.08] * 3, np.eye(3), clip=False), 0.02, rng)
        (o,) = _localize(poses, boxes)
        assert o.shape == "sphere" and "solid" not in o.extra
        assert np.linalg.norm(o.position - TARGET) < 8e-3


def test_a_solid_is_fitted_only_where_it_could_win():
    # exact boxes of a spheroid: the spheroid fits them closely, so a cuboid has nothing to show and is not fitted;
    # a flat tray's boxes: the spheroid misses them by about 10 px, within the sensor model's noise, and the cuboid is
    rng = np.random.default_rng(12)
    poses = _poses(rng, 3, 10.0)
    spheroid = ellipsoid_bbox(CAM, poses, TARGET, [R_M, R_M, H_M], rotation_upright(0.0), clip=False)
    tray = cuboid_bbox(CAM, poses, TARGET, [0.10, 0.08, 0.015], rotation_upright(0.7))
    for boxes, expected in ((spheroid, False), (tray, True)):
        _, fits = fit_shape_by_bic(CAM, poses, boxes, shapes=("sphere", "spheroid"), box_sigma=0.05, size_range=(0.005, 0.15))
        assert 7 * np.log(fits["spheroid"].n_edges) > fits["spheroid"].bic  # by the BIC alone no cuboid could win
        assert solid_may_win("cuboid", fits) is expected
    fitted: list[str] = []
    real_fit = fit_module.fit_ellipsoid_to_boxes

    def counting(*args, shape: str = "spheroid", **kwargs):
        fitted.append(shape)
        return real_fit(*args, shape=shape, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(fit_module, "fit_ellipsoid_to_boxes", counting)
        (o,) = _localize(poses, spheroid)
    assert o.shape == "spheroid" and "spheroid" in fitted and "cuboid" not in fitted  # the shape stage skipped it


def test_a_flat_trays_cuboid_is_fitted_where_a_spheroid_fits_within_the_noise_but_not_to_the_pixel():
    # a flat tray seen from its height: a spheroid, round in plan, follows the rectangle's box widths by moving in
    # depth, and fits them 4-9 px RMS, well within the sensor model's 5 % edge noise (precise); the cuboid fits them
    # to under a pixel. Skipping the cuboid where a spheroid is precise left these seeds 5-15 mm off as spheroids
    # or cylinders; it is skipped only where an ellipsoid model also fits to the pixel (exact boxes of a fruit)
    for seed in (16, 22, 28, 34, 37, 39):
        rng = np.random.default_rng(seed)
        poses = _poses(rng, 3, 0.0)
        yaw = rng.uniform(0.0, np.pi)
        boxes = perturb_boxes(cuboid_bbox(CAM, poses, TARGET, [0.10, 0.08, 0.015], rotation_upright(yaw)), 0.002, rng)
        _, fits = fit_shape_by_bic(CAM, poses, boxes, shapes=("sphere", "spheroid"), box_sigma=0.05, size_range=(0.005, 0.15))
        spheroid = fits["spheroid"]
        assert precise(spheroid) and spheroid.rms_px > 4.0
        assert np.linalg.norm(spheroid.ellipsoid.centre_base - TARGET) > 5e-3
        assert solid_may_win("cuboid", fits)
        (o,) = _localize(poses, boxes)
        assert o.extra.get("solid") == "cuboid"
        assert np.linalg.norm(o.position - TARGET) < 1.5e-3


def test_a_trays_cuboid_wins_by_its_box_sizes_where_pose_errors_move_the_boxes():
    # each view's box moved by 4 px across and 6 px up or down, as an arm's unstated pose error moves it: on the tray's
    # thin side (4-5 px of edge noise) those moves outweigh what the edges say about the shape, and the edges' evidence
    # leaves the cuboid out; its box sizes, which the moves leave as they are, speak for it by about 10 nats
    for seed in (44, 53, 59):
        rng = np.random.default_rng(seed)
        poses = _poses(rng, 3, 0.0)
        boxes = cuboid_bbox(CAM, poses, TARGET, [0.10, 0.08, 0.015], rotation_upright(rng.uniform(0.0, np.pi)))
        shift = rng.choice([-1.0, 1.0], size=(3, 2)) * np.array([4.0, 6.0])
        boxes = boxes + np.hstack([shift, shift])
        models = ("sphere", "spheroid", "ellipsoid", "cylinder", "cuboid")
        best, fits = fit_shape_by_bic(CAM, poses, boxes, shapes=models, box_sigma=0.05, size_range=(0.005, 0.15))
        other = min((f for m, f in fits.items() if m not in ("cylinder", "cuboid")), key=lambda f: f.bic)
        cuboid = fits["cuboid"]
        assert not (precise(cuboid) and solid_evidence(cuboid, other) > SOLID_EVIDENCE_NATS)  # the edges alone
        assert precise(cuboid, sizes=True) and solid_evidence(cuboid, other, sizes=True) > 5.0
        assert solid_if_clear(best, fits) is cuboid
        errors = [np.linalg.norm(f.ellipsoid.centre_base - TARGET) for f in (cuboid, other)]
        assert errors[0] < 5e-3 and errors[1] > 1.5 * errors[0]


def test_size_residuals_pair_the_two_edges_of_each_axis_the_fit_used():
    rng = np.random.default_rng(3)
    poses = _poses(rng, 3, 10.0)
    boxes = perturb_boxes(cuboid_bbox(CAM, poses, TARGET, [R_M, R_M, H_M], rotation_upright(0.3)), 0.01, rng)
    censored = np.zeros((3, 4), dtype=bool)
    censored[1, 2] = True  # view 1's right edge: its width is not a size the fit saw
    fit = fit_shape_by_bic(CAM, poses, boxes, shapes=("spheroid",), censored=censored)[0]
    misses, sigmas = size_residuals(fit)
    assert fit.used.shape == (3, 4) and fit.used.sum() == len(fit.residuals_px) == 11
    r = np.full((3, 4), np.nan)
    r[fit.used] = fit.residuals_px
    expected = np.concatenate([[r[0, 2] - r[0, 0], r[2, 2] - r[2, 0]], r[:, 3] - r[:, 1]])
    assert_allclose(misses, expected, atol=1e-12)
    assert sigmas.shape == (5,) and np.all(sigmas > 0)


def test_an_upright_spheroid_stays_a_spheroid():
    rng = np.random.default_rng(6)
    poses = _poses(rng, 3, 25.0)
    objects = _localize(poses, ellipsoid_bbox(CAM, poses, TARGET, [R_M, R_M, H_M], rotation_upright(0.0), clip=False))
    assert len(objects) == 1
    o = objects[0]
    assert o.shape == "spheroid" and "solid" not in o.extra
    assert np.linalg.norm(o.position - TARGET) < 3e-4


def test_a_sphere_is_not_fitted_as_a_solid():
    rng = np.random.default_rng(7)
    poses = _poses(rng, 3, 25.0)
    objects = _localize(poses, ellipsoid_bbox(CAM, poses, TARGET, [0.03] * 3, np.eye(3), clip=False))
    assert len(objects) == 1
    assert objects[0].shape == "sphere" and "solid" not in objects[0].extra


def test_solid_evidence_is_decisive_on_exact_boxes_and_small_on_noisy_ones():
    rng = np.random.default_rng(8)
    poses = _poses(rng, 3, 25.0)
    shapes = ("spheroid", "cylinder")
    exact = {
        "cylinder": cylinder_bbox(CAM, poses, TARGET, R_M, H_M, rotation_upright(0.0)),
        "spheroid": ellipsoid_bbox(CAM, poses, TARGET, [R_M, R_M, H_M], rotation_upright(0.0), clip=False),
    }
    for kind, boxes in exact.items():
        _, fits = fit_shape_by_bic(CAM, poses, boxes, shapes=shapes, box_sigma=0.05)
        evidence = solid_evidence(fits["cylinder"], fits["spheroid"])
        assert (evidence > 100.0) if kind == "cylinder" else (evidence < -100.0)
        assert solid_if_clear(fits["cylinder"], fits).model == kind
    # 2 % box noise (about 4 px an edge here) hides the difference (about 1 px): the evidence is of the order of a nat
    evidence = []
    for seed in range(10):
        noisy = perturb_boxes(exact["spheroid"], 0.02, np.random.default_rng(100 + seed))
        _, fits = fit_shape_by_bic(CAM, poses, noisy, shapes=shapes, box_sigma=0.05)
        evidence.append(solid_evidence(fits["cylinder"], fits["spheroid"]))
    assert np.all(np.abs(evidence) < 10.0)
    assert np.mean(np.array(evidence) > SOLID_EVIDENCE_NATS) <= 0.3


def test_solids_are_on_by_default_and_can_be_turned_off():
    rng = np.random.default_rng(9)
    poses = _poses(rng, 3, 25.0)
    boxes = cylinder_bbox(CAM, poses, TARGET, R_M, H_M, rotation_upright(0.0))
    assert BayesConfig().solids is True
    objects = _localize(poses, boxes, solids=False)
    assert len(objects) == 1 and "solid" not in objects[0].extra
    with pytest.raises(ValueError, match="solids"):
        BayesConfig(solids="yes")


def test_the_cli_has_the_solids_flag(tmp_path):
    rng = np.random.default_rng(10)
    poses = _poses(rng, 3, 25.0)
    boxes = cylinder_bbox(CAM, poses, TARGET, R_M, H_M, rotation_upright(0.0))
    session = Session(CAM, tuple(View(T, (Detection(b),)) for T, b in zip(poses, boxes)), Workspace(TARGET - 0.2, TARGET + 0.2))
    path = tmp_path / "session.json"
    path.write_text(json.dumps(session.to_dict()))
    out = tmp_path / "objects.json"
    result = CliRunner().invoke(app, ["localize", str(path), "-o", str(out)])  # on by default
    assert result.exit_code == 0, result.output
    objects = json.loads(out.read_text())["objects"]
    assert len(objects) == 1 and objects[0]["solid"] == "cylinder"
    assert_allclose(objects[0]["position"], TARGET, atol=3e-4)
    result = CliRunner().invoke(app, ["localize", str(path), "--no-solids", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "solid" not in json.loads(out.read_text())["objects"][0]


def test_two_containers_side_by_side_seen_side_on_keep_their_centres():
    """Two upright cylinders 57 mm apart seen from the side (camera at their height): in the views where one hides
    part of the other, the farther box ends at the nearer box's edge, as a detector of visible parts draws it. The
    shape fit leaves out the edge the nearer container covers along its whole side (occlusion.covered_sides); taking it
    at face value put the farther container 12-20 mm off in most such three-view sets."""
    centres = TARGET + np.array([[0.0, -0.0285, 0.0], [0.0, 0.0285, 0.0]])
    errors = []
    for seed in range(3):
        rng = np.random.default_rng(seed)
        poses = []
        for az in np.radians([-64.0, -39.0, 13.0]):
            p = TARGET + rng.uniform(0.5, 0.7) * np.array([-np.cos(az), np.sin(az), 0.0])
            poses.append(look_at(p, TARGET + rng.uniform(-0.01, 0.01, 3)))
        poses = np.array(poses)
        boxes = np.stack([cylinder_bbox(CAM, poses, c, R_M, H_M, rotation_upright(0.0)) for c in centres], axis=1)
        depth = np.einsum("kj,nj->kn", np.linalg.inv(poses)[:, 2, :3], centres) + np.linalg.inv(poses)[:, 2, 3:4]
        boxes = visible_part_boxes(boxes, depth)  # the farther box ends where the nearer one begins
        errors.append(_pair_error(poses, boxes, centres))
    assert max(errors) < 3e-3, errors


def test_two_box_containers_with_whole_boxes_seen_nearly_side_on_keep_their_centres():
    """Two upright 50 x 50 x 120 mm boxes 57 mm apart, seen 10 degrees from above, from three views on the side where one
    stands behind the other, with whole (amodal) boxes, as an annotator draws them. The farther box's edge lies inside
    the nearer box, not at its edge: it is the object's own edge, and the shape fit keeps it
    (occlusion.ends_at_occluder). Left out, a sphere of the containers' height explained the rest of the farther box
    and took its place, about 33 mm off (this test fails without it)."""
    centres = TARGET + np.array([[0.0, -0.0285, 0.0], [0.0, 0.0285, 0.0]])
    for seed in range(3):
        rng = np.random.default_rng(seed)
        poses = []
        for az, el in zip(np.radians([-116.0, -141.0, -167.0]), np.radians([10.0] * 3)):
            p = TARGET + rng.uniform(0.5, 0.7) * np.array([np.cos(az) * np.cos(el), np.sin(az) * np.cos(el), np.sin(el)])
            poses.append(look_at(p, TARGET + rng.uniform(-0.01, 0.01, 3)))
        poses = np.array(poses)
        yaws = rng.uniform(0.0, np.pi / 2, 2)
        half = np.array([0.025, 0.025, 0.06])
        boxes = np.stack([cuboid_bbox(CAM, poses, c, half, rotation_upright(y)) for c, y in zip(centres, yaws)], axis=1)
        boxes = perturb_boxes(boxes.reshape(-1, 4), 0.005, rng).reshape(boxes.shape)
        assert _pair_error(poses, boxes, centres) < 8e-3, seed
