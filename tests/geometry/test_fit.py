"""Least-squares shape fits to associated boxes."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.geometry import Ellipsoid, rotation_upright
from monovisual3d.geometry.fit import (
    ellipsoid_from_parameters,
    fit_ellipsoid_boxes,
    fit_ellipsoid_to_boxes,
    fit_parameters,
    fit_shape_by_bic,
)
from monovisual3d.session import Detection, View
from monovisual3d.sim import EllipsoidFruit, Scene
from monovisual3d.sim.scenes import default_camera
from monovisual3d.sim.simulate import simulate_views
from monovisual3d.sim.viewpoints import paper_poses

CAM = default_camera()
P = paper_poses()


def tilted(tilt_deg: float, axis_deg: float = 30.0, yaw: float = 0.4, semi_axes=(0.022, 0.022, 0.09)) -> Ellipsoid:
    axis = np.array([np.cos(np.radians(axis_deg)), np.sin(np.radians(axis_deg)), 0.0])
    R = Rotation.from_rotvec(np.radians(tilt_deg) * axis).as_matrix() @ rotation_upright(yaw)
    return Ellipsoid.from_rotation([0.6, 0.03, 0.44], semi_axes, R)


def rendered_boxes(e: Ellipsoid, poses: np.ndarray, supersample: int = 1) -> np.ndarray:
    """Noise-free boxes of the ray-cast camera (edges on the 1 / supersample pixel grid)."""
    views = simulate_views(Scene((EllipsoidFruit.from_ellipsoid(e, "cucumber"),)), CAM, poses, supersample=supersample)
    return np.array([v.rendering.boxes_xyxy[0] for v in views])


def errors_mm(fit, truth: Ellipsoid) -> tuple[float, float]:
    centre = np.linalg.norm(fit.ellipsoid.centre_base - truth.centre_base) * 1e3
    axes = np.abs(np.sort(fit.ellipsoid.semi_axes) - np.sort(truth.semi_axes)).max() * 1e3
    return float(centre), float(axes)


@pytest.mark.parametrize(
    ("truth", "shape", "free"),
    [
        (Ellipsoid.spheroid([0.6, 0.03, 0.44], 0.022, 0.09), "spheroid", False),
        (Ellipsoid.upright([0.6, 0.03, 0.44], [0.045, 0.035, 0.06], 0.5), "ellipsoid", False),
        (Ellipsoid.sphere([0.6, 0.03, 0.44], 0.03), "sphere", False),
        (tilted(12.0), "spheroid", True),
    ],
    ids=["spheroid", "ellipsoid-yaw", "sphere", "tilted-spheroid"],
)
def test_exact_boxes_give_the_exact_object(truth: Ellipsoid, shape: str, free: bool) -> None:
    fit = fit_ellipsoid_to_boxes(CAM, P, truth.bbox(CAM, P), shape=shape, free_orientation=free)
    assert fit.success and fit.model == shape and fit.n_edges == 12 and fit.n_views == 3
    c, a = errors_mm(fit, truth)
    assert c < 1e-3 and a < 1e-3
    assert fit.rms_px < 1e-4
    assert fit.centre_covariance.shape == (3, 3) and np.all(np.linalg.eigvalsh(fit.centre_covariance) > 0)


def test_a_sphere_given_to_the_ellipsoid_model_comes_back_with_equal_semi_axes() -> None:
    truth = Ellipsoid.sphere([0.6, -0.1, 0.5], 0.035)
    fit = fit_ellipsoid_to_boxes(CAM, P, truth.bbox(CAM, P), shape="ellipsoid")
    assert_allclose(fit.ellipsoid.semi_axes, 0.035, atol=1e-6)
    assert fit.ellipsoid.shape == "sphere" or np.ptp(fit.ellipsoid.semi_axes) < 1e-6


def test_recovers_a_simulated_cucumber_from_three_noise_free_views() -> None:
    """The ray-cast camera's boxes (whole pixels): upright cucumber within 1.5 mm and 2 mm semi-axes."""
    truth = Ellipsoid.spheroid([0.62, -0.05, 0.43], 0.022, 0.09)
    fit = fit_ellipsoid_to_boxes(CAM, P, rendered_boxes(truth, P), shape="spheroid")
    c, a = errors_mm(fit, truth)
    assert c <= 1.5 and a <= 2.0, (c, a)
    # tilted 15 degrees: the upright model cannot, the free orientation can
    truth = tilted(15.0, axis_deg=70.0)
    boxes = rendered_boxes(truth, P, supersample=2)
    c, a = errors_mm(fit_ellipsoid_to_boxes(CAM, P, boxes, shape="spheroid", free_orientation=True), truth)
    assert c <= 1.5 and a <= 2.0, (c, a)


def test_bic_prefers_the_sphere_for_a_round_fruit_and_the_spheroid_for_a_cucumber() -> None:
    sphere = Ellipsoid.sphere([0.6, 0.1, 0.4], 0.03)
    b = rendered_boxes(sphere, P)
    bic = {m: fit_ellipsoid_to_boxes(CAM, P, b, shape=m).bic for m in ("sphere", "spheroid", "ellipsoid")}
    assert min(bic, key=bic.get) == "sphere"
    cucumber = Ellipsoid.spheroid([0.6, 0.1, 0.4], 0.022, 0.09)
    b = rendered_boxes(cucumber, P)
    bic = {m: fit_ellipsoid_to_boxes(CAM, P, b, shape=m).bic for m in ("sphere", "spheroid")}
    assert bic["spheroid"] < bic["sphere"] - 100


def test_robust_loss_resists_one_bad_edge() -> None:
    truth = Ellipsoid.spheroid([0.6, 0.03, 0.44], 0.03, 0.05)
    poses = np.concatenate([P, [look_at([0.1, 0.1, 0.45], truth.centre_base), look_at([0.15, -0.15, 0.3], truth.centre_base)]])
    boxes = truth.bbox(CAM, poses)
    boxes[1, 3] -= 40.0  # a leaf hides the bottom of the fruit in view 1: the box is 40 px short
    robust = fit_ellipsoid_to_boxes(CAM, poses, boxes, shape="spheroid")
    plain = fit_ellipsoid_to_boxes(CAM, poses, boxes, shape="spheroid", loss="linear")
    assert errors_mm(robust, truth)[0] < 0.5 * errors_mm(plain, truth)[0]
    assert errors_mm(robust, truth)[0] < 1.0
    assert np.argmax(np.abs(robust.residuals_px)) == 4 * 1 + 3  # the bad edge stands out
    for loss in ("huber", "arctan"):  # scipy's other robust losses also hold the edge back
        assert (
            errors_mm(fit_ellipsoid_to_boxes(CAM, poses, boxes, shape="spheroid", loss=loss), truth)[0]
            < errors_mm(plain, truth)[0]
        )


def test_edges_on_the_image_border_are_not_counted_and_do_not_pull() -> None:
    """A box clipped by the image border: its border edge is not counted in ``n_edges`` and does not pull the fit
    inward (it counts one-sided); taken at face value, it does."""
    truth = Ellipsoid.spheroid([0.6, 0.03, 0.44], 0.03, 0.05)
    # a view that cuts the fruit at its left border
    T = look_at([0.15, 0.0, 0.44], [0.6, -0.25, 0.44])
    poses = np.concatenate([P, T[None]])
    boxes = truth.bbox(CAM, poses)  # clipped like a detector's
    assert boxes[3, 0] == 0.0 or boxes[3, 2] == CAM.width
    fit = fit_ellipsoid_to_boxes(CAM, poses, boxes, shape="spheroid")
    assert fit.n_edges == 15
    assert errors_mm(fit, truth)[0] < 1e-3
    naive = fit_ellipsoid_to_boxes(CAM, poses, boxes, shape="spheroid", border_px=-1.0, loss="linear")
    assert naive.n_edges == 16 and errors_mm(naive, truth)[0] > 0.1


def test_fit_from_session_views_and_associations() -> None:
    truth = Ellipsoid.spheroid([0.6, 0.03, 0.44], 0.022, 0.09)
    boxes = truth.bbox(CAM, P)
    other = Detection(np.array([10.0, 10.0, 30.0, 30.0]))
    views = [View(T, (other, Detection(b)) if i != 1 else (Detection(b),)) for i, (T, b) in enumerate(zip(P, boxes))]
    fit = fit_ellipsoid_boxes(CAM, views, {0: 1, 1: 0, 2: 1}, shape="spheroid")
    assert errors_mm(fit, truth)[0] < 1e-3
    with pytest.raises(InputError, match="associations: view 5 does not exist"):
        fit_ellipsoid_boxes(CAM, views, {5: 0})
    with pytest.raises(InputError, match="associations: view 1 has no detection 1"):
        fit_ellipsoid_boxes(CAM, views, {0: 1, 1: 1})


def test_parameters_round_trip() -> None:
    for model, free in (("sphere", False), ("spheroid", False), ("spheroid", True), ("ellipsoid", False), ("ellipsoid", True)):
        names = fit_parameters(model, free_orientation=free)
        theta = np.r_[0.6, 0.0, 0.4, np.log(np.linspace(0.02, 0.05, len(names) - 3)).clip(-5)]
        c, s, R = ellipsoid_from_parameters(theta, model, free_orientation=free)
        assert c.shape == (3,) and s.shape == (3,) and R.shape == (3, 3)
        assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        batch = ellipsoid_from_parameters(np.stack([theta, theta]), model, free_orientation=free)
        assert batch[2].shape == (2, 3, 3)


def test_bad_input() -> None:
    b = Ellipsoid.spheroid([0.6, 0.0, 0.45], 0.03, 0.05).bbox(CAM, P)
    with pytest.raises(InputError, match="shape: got 'cube'"):
        fit_ellipsoid_to_boxes(CAM, P, b, shape="cube")
    with pytest.raises(InputError, match=r"size_range: got \(0.2, 0.1\), expected 0 < min < max"):
        fit_ellipsoid_to_boxes(CAM, P, b, size_range=(0.2, 0.1))
    with pytest.raises(InputError, match=r"size_range: got \(-0.01, 0.1\)"):
        fit_ellipsoid_to_boxes(CAM, P, b, size_range=(-0.01, 0.1))
    with pytest.raises(InputError, match="up: zero length"):
        fit_ellipsoid_to_boxes(CAM, P, b, up=(0, 0, 0))
    with pytest.raises(InputError, match="4 usable box edges .* cannot fix the 5 parameters of a spheroid"):
        fit_ellipsoid_to_boxes(CAM, P[:1], b[:1], shape="spheroid")
    with pytest.raises(InputError, match="got 2 boxes for 3 poses"):
        fit_ellipsoid_to_boxes(CAM, P, b[:2])
    with pytest.raises(InputError, match="not both 0"):
        fit_ellipsoid_to_boxes(CAM, P, b, box_sigma=0.0, edge_sigma_px=0.0)
    with pytest.raises(InputError, match="loss: got 'l1', expected one of linear, soft_l1, huber, cauchy, arctan"):
        fit_ellipsoid_to_boxes(CAM, P, b, loss="l1")


def test_bic_keeps_the_paper_spheres_spheres() -> None:
    from monovisual3d.sim.noise import NoiseModel
    from monovisual3d.sim.scenes import paper_scene

    scene = paper_scene()
    for noise in (NoiseModel(), NoiseModel(box_sigma=0.05)):
        views = simulate_views(scene, CAM, P, noise=noise, rng=0)
        for i in range(len(scene.fruits)):
            seen = [(v.T_base_optical_true, v.boxes_xyxy[np.flatnonzero(v.source == i)[0]]) for v in views if i in v.source]
            best, fits = fit_shape_by_bic(CAM, np.array([s[0] for s in seen]), np.array([s[1] for s in seen]))
            assert best.model == "sphere" and set(fits) == {"sphere", "spheroid", "ellipsoid"}
    # one view: only the sphere can be fitted
    b = Ellipsoid.sphere([0.6, 0.0, 0.45], 0.03).bbox(CAM, P[:1])
    best, fits = fit_shape_by_bic(CAM, P[:1], b)
    assert best.model == "sphere" and set(fits) == {"sphere"}
    with pytest.raises(InputError, match="cannot fix the 5 parameters of a spheroid"):
        fit_shape_by_bic(CAM, P[:1], b, shapes=("spheroid", "ellipsoid"))


def test_censored_edges_do_not_pull_the_fit():
    """An edge cut by an occluder, flagged as censored, counts one-sided and no longer pulls the fit inward: the cut box's other edges and the
    other views fix the spheroid exactly; a flag array of the wrong shape is refused."""
    cam, poses = default_camera(), paper_poses()
    true = Ellipsoid.spheroid([0.6, 0.02, 0.45], 0.022, 0.06)
    boxes = true.bbox(cam, poses)
    boxes[1, 2] -= 0.4 * (boxes[1, 2] - boxes[1, 0])  # a nearer object hides the right 40 % in view 1
    censored = np.zeros(boxes.shape, dtype=bool)
    censored[1, 2] = True
    fit = fit_ellipsoid_to_boxes(cam, poses, boxes, shape="spheroid", censored=censored)
    assert fit.n_edges == boxes.size - 1
    assert_allclose(fit.ellipsoid.centre_base, true.centre_base, atol=1e-5)
    cut = fit_ellipsoid_to_boxes(cam, poses, boxes, shape="spheroid", loss="linear")
    assert np.linalg.norm(cut.ellipsoid.centre_base - true.centre_base) > 1e-3  # taken at face value, it pulls
    with pytest.raises(InputError, match=r"^censored: got shape \(3,\), expected \(3, 4\)"):
        fit_ellipsoid_to_boxes(cam, poses, boxes, shape="spheroid", censored=np.zeros(3, dtype=bool))


def test_a_censored_edge_still_bounds_the_object_from_inside() -> None:
    """A hidden edge says the object reaches at least that far: a tall container whose bottom edges a nearer object
    hides in every view is not a sphere of its width sitting at its top (which fits every other edge), as when those
    edges were left out; the edges stay out of ``n_edges``, and a prediction beyond a hidden edge costs nothing."""
    true = Ellipsoid.spheroid([0.6, 0.02, 0.45], 0.025, 0.06)
    boxes = true.bbox(CAM, P)
    censored = np.zeros(boxes.shape, dtype=bool)
    censored[:, 3] = True  # the bottom edge (y2) of every view
    best, fits = fit_shape_by_bic(CAM, P, boxes, shapes=("sphere", "spheroid"), censored=censored)
    assert best.model == "spheroid" and best.n_edges == boxes.size - len(P)
    assert_allclose(best.ellipsoid.centre_base, true.centre_base, atol=1e-5)
    assert fits["sphere"].chi2 > 100  # the sphere cannot reach down to the hidden edges without missing the others
    short = boxes.copy()
    short[:, 3] -= 0.3 * (boxes[:, 3] - boxes[:, 1])  # boxes of the visible part: the container continues behind
    fit = fit_ellipsoid_to_boxes(CAM, P, short, shape="spheroid", censored=censored, loss="linear")
    assert_allclose(fit.ellipsoid.centre_base, true.centre_base, atol=1e-5)
    assert fit.chi2 < 1e-8
    # residuals are those of the seen edges, in row-major order, with a hidden edge in the middle of the array
    noisy = boxes * (1 + np.random.default_rng(3).normal(0, 0.01, boxes.shape))
    middle = np.zeros(boxes.shape, dtype=bool)
    middle[1, 1] = True
    fit = fit_ellipsoid_to_boxes(CAM, P, noisy, shape="spheroid", censored=middle)
    assert len(fit.residuals_px) == fit.n_edges == boxes.size - 1
    assert_allclose(fit.residuals_px, (fit.ellipsoid.bbox(CAM, P) - noisy)[~middle], atol=1e-6)


def test_a_hidden_edge_is_hidden_no_further_than_its_occluder() -> None:
    """A tall object behind a nearer one, boxes of its visible part (the right 70 % hidden in every view): with the
    hidden edges open-ended, a sphere 34 mm off whose right side reaches far behind the occluder fits almost as well
    as the truth (the BIC's one parameter apart); with ``hidden_to`` at the occluder's far side it cannot reach past
    it, the sphere no longer fits and the spheroid stays exact; a limit array of the wrong shape is refused."""
    true = Ellipsoid.spheroid([0.6, 0.02, 0.45], 0.025, 0.06)
    whole = true.bbox(CAM, P)
    visible = whole.copy()
    visible[:, 2] = whole[:, 0] + 0.3 * (whole[:, 2] - whole[:, 0])
    censored = np.zeros(whole.shape, dtype=bool)
    censored[:, 2] = True
    occluder_far_side = np.where(censored, whole + 5.0, np.nan)  # the nearer box ends 5 px past the object's edge
    shapes = ("sphere", "spheroid")
    _, open_ended = fit_shape_by_bic(CAM, P, visible, shapes=shapes, censored=censored)
    best, bounded = fit_shape_by_bic(CAM, P, visible, shapes=shapes, censored=censored, hidden_to=occluder_far_side)
    assert open_ended["sphere"].chi2 < 5 and np.linalg.norm(open_ended["sphere"].ellipsoid.centre_base - true.centre_base) > 0.02
    assert np.all(open_ended["sphere"].ellipsoid.bbox(CAM, P)[:, 2] > occluder_far_side[:, 2] + 20)
    assert bounded["sphere"].chi2 > 100
    assert best.model == "spheroid" and best.chi2 < 1e-8
    assert_allclose(best.ellipsoid.centre_base, true.centre_base, atol=1e-5)
    with pytest.raises(InputError, match=r"^hidden_to: got shape \(3,\), expected \(3, 4\)"):
        fit_ellipsoid_to_boxes(CAM, P, visible, shape="spheroid", censored=censored, hidden_to=np.zeros(3))


def test_an_edge_on_the_image_border_still_bounds_the_object_from_inside() -> None:
    """A tall object whose top lies beyond the image's top border in every view (a hanging fruit seen from close by):
    the border edges say it reaches at least there, so it is not a sphere of its width at its bottom, which fits every
    other edge exactly (35 mm off when border edges were left out)."""
    true = Ellipsoid.spheroid([0.6, 0.02, 0.765], 0.025, 0.06)
    boxes = true.bbox(CAM, P)
    assert np.all(boxes[:, 1] <= 1.0) and np.all(boxes[:, 3] > 1.0)  # tops on the border, bottoms in the image
    best, fits = fit_shape_by_bic(CAM, P, boxes, shapes=("sphere", "spheroid"))
    assert best.model == "spheroid" and best.n_edges == boxes.size - len(P)
    assert_allclose(best.ellipsoid.centre_base, true.centre_base, atol=1e-5)
    assert fits["sphere"].chi2 > 10


def test_a_model_left_out_for_its_penalty_could_not_have_won() -> None:
    """``every_model=False`` keeps the best fit of every model fitted: on noisy boxes of spheres, spheroids and boxes
    cut short, the same best model and numbers, and each model left out has a penalty ``P ln E`` above the lowest BIC
    (of the ellipsoid models, for one of them) that the full comparison found."""
    from monovisual3d.geometry.solids import SOLIDS

    rng = np.random.default_rng(4)
    shapes = ("sphere", "spheroid", "ellipsoid", "cylinder", "cuboid")
    left_out = 0
    for case in range(12):
        e = Ellipsoid.sphere([0.6, 0.02, 0.45], 0.03) if case % 2 else Ellipsoid.spheroid([0.6, 0.02, 0.45], 0.025, 0.05)
        b = e.bbox(CAM, P) * (1 + rng.normal(0, 0.002 + 0.01 * (case % 3), (len(P), 4)))
        b[0, 2] -= 6.0 * (case % 4 == 0)  # a cut edge
        order = shapes if case < 6 else shapes[::-1]  # solids first: an ellipsoid model has only its kind as rivals
        best, fits = fit_shape_by_bic(CAM, P, b, shapes=order, box_sigma=0.03)
        lean_best, lean = fit_shape_by_bic(CAM, P, b, shapes=order, box_sigma=0.03, every_model=False)
        assert lean_best.model == best.model and lean_best.bic == best.bic
        assert set(lean) <= set(fits) and all(lean[m].bic == fits[m].bic for m in lean)
        for m in set(fits) - set(lean):
            fitted_before = [k for k in order[: order.index(m)] if k in lean]
            rivals = [fits[k].bic for k in fitted_before if m in SOLIDS or k not in SOLIDS]
            assert len(fit_parameters(m)) * np.log(fits[m].n_edges) > min(rivals)
            left_out += 1
    assert left_out >= 3  # the test saw the shortcut
