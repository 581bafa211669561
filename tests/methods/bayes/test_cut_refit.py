"""The ``bayes`` final sphere refit with a one-sided loss: an edge inside the prediction (a leaf's cut) stops pulling
sooner than one outside (:func:`monovisual3d.methods.bayes.shapes.one_sided_refit`)."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

import monovisual3d as mv
from monovisual3d.camera import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.ellipsoid import ellipsoid_bbox
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.methods.bayes.refine import one_sided_residuals, robust_loss
from monovisual3d.session import Detection, Session, View
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import default_camera, greenhouse_scene
from monovisual3d.sim.simulate import simulate_views

CAM = Camera.from_hfov(640, 480, 69.0)
TARGET = np.array([0.7, 0.0, 0.5])


def _poses():
    return [look_at(TARGET + [-0.5, y, 0.03 * k], TARGET) for k, y in enumerate((-0.12, -0.04, 0.04, 0.12))]


def _error(session, centre, **options):
    res = mv.localize(session, method="bayes", use_masks=False, **options)
    assert len(res.objects) == 1
    return float(np.linalg.norm(res.objects[0].position - centre))


def _session(boxes):
    return Session(CAM, tuple(View(T, (Detection(b, label="fruit"),)) for T, b in zip(_poses(), boxes)))


def test_a_leaf_cut_of_two_to_four_sigmas_pulls_the_sphere_less():
    c, r = np.array([0.71, 0.02, 0.48]), 0.03
    rng = np.random.default_rng(5)
    exact = [sphere_bbox(CAM, T, c[None], r)[0] + rng.normal(0.0, 0.3, 4) for T in _poses()]
    for frac in (0.13, 0.16, 0.2):  # a leaf cuts the right edge of one box by about 2.3, 2.8 and 3.5 sensor sigmas
        boxes = [b.copy() for b in exact]
        boxes[1][2] -= frac * (boxes[1][2] - boxes[1][0])
        one_sided = _error(_session(boxes), c, cut_inward_floor=1.5)
        symmetric = _error(_session(boxes), c, one_sided_refit=False)  # the refinement's symmetric loss
        assert symmetric > 1.5e-3  # the symmetric loss still follows the cut
        assert one_sided < 0.85 * symmetric


def test_uncut_boxes_give_nearly_the_same_estimate_with_either_loss():
    c, r = np.array([0.69, -0.02, 0.51]), 0.035
    rng = np.random.default_rng(8)
    boxes = [sphere_bbox(CAM, T, c[None], r)[0] + rng.normal(0.0, 0.5, 4) for T in _poses()]
    a = mv.localize(_session(boxes), method="bayes", use_masks=False).objects[0].position
    b = mv.localize(_session(boxes), method="bayes", use_masks=False, one_sided_refit=False).objects[0].position
    assert_allclose(a, b, atol=0.2e-3)  # both about 3 mm off (depth from a 24 cm baseline); the loss moves it < 0.2 mm


def test_occlusion_only_shrinks_a_box_in_the_simulated_greenhouse():
    """The physical reason for one-sided censoring: a leaf or a nearer fruit only ever cuts a fruit's box."""
    cam = default_camera()
    inward = []
    for seed in (11, 12):
        scene = greenhouse_scene(rng=seed)
        for sv in simulate_views(scene, cam, noise=NoiseModel(), rng=seed):
            for f, fruit in enumerate(scene.fruits):
                seen = sv.rendering.boxes_xyxy[f]
                if not np.all(np.isfinite(seen)):
                    continue
                e = fruit.ellipsoid
                full = ellipsoid_bbox(cam, sv.T_base_optical_true[None], e.centre_base, e.semi_axes, e.rotation)[0]
                inward.append([seen[0] - full[0], seen[1] - full[1], full[2] - seen[2], full[3] - seen[3]])
    d = np.array(inward)
    assert len(d) > 20
    assert d.min() > -1.0  # never outside the silhouette box by more than the rendering's pixel
    assert np.mean(d > 1.5) > 0.1  # and often cut


def test_one_sided_residuals_square_to_the_robust_loss_with_the_floor_of_their_side():
    e = np.random.default_rng(2).normal(0.0, 3.0, 200)
    r = one_sided_residuals(e, 2.0, 6.0)
    expect = np.where(e > 0, robust_loss(2.0)(e * e)[0], robust_loss(6.0)(e * e)[0])
    assert_allclose(r * r, expect, rtol=1e-12, atol=1e-12)
    assert np.all(np.sign(r) == np.sign(e))
    small = np.array([-1e-4, 1e-4])
    # near 0 the plain residual (scaled as the loss is: rho'(0) = 1 / (1 + exp(-floor)))
    assert_allclose(one_sided_residuals(small, 2.0, 6.0), small / np.sqrt(1 + np.exp([-6.0, -2.0])), rtol=1e-6)
    # an edge far inside costs at most its floor (2 nats: r^2 / 2), one far outside up to 6
    assert_allclose(one_sided_residuals(np.array([50.0, -50.0]), 2.0, 6.0) ** 2 / 2, [2.0, 6.0], rtol=0.1)


def test_a_sphere_seen_in_two_views_keeps_the_symmetric_fit():
    """From two views the 8 edges barely fix the 4 parameters: no edge can be told a cut (MIN_VIEWS_ONE_SIDED)."""
    c, r = np.array([0.71, 0.02, 0.48]), 0.03
    boxes = [sphere_bbox(CAM, T, c[None], r)[0] for T in _poses()[::3]]
    boxes[1][2] -= 0.16 * (boxes[1][2] - boxes[1][0])
    session = Session(CAM, tuple(View(T, (Detection(b, label="fruit"),)) for T, b in zip(_poses()[::3], boxes)))
    a = mv.localize(session, method="bayes", use_masks=False).objects[0].position
    b = mv.localize(session, method="bayes", use_masks=False, one_sided_refit=False).objects[0].position
    assert_allclose(a, b, atol=1e-12)


def test_the_one_sided_refit_options_are_checked_and_on_the_cli():
    import pytest

    from monovisual3d.cli.options import option_specs
    from monovisual3d.errors import InputError
    from monovisual3d.methods.bayes import BayesConfig

    with pytest.raises(InputError, match="cut_inward_floor"):
        BayesConfig.from_options(cut_inward_floor=0.0)
    with pytest.raises(InputError, match="one_sided_refit"):
        BayesConfig.from_options(one_sided_refit="yes")
    typed = {s.typed for s in option_specs()}  # developer knobs (BayesTuning): set with --set NAME=VALUE
    assert {"--set cut_inward_floor", "--set one_sided_refit"} <= typed
