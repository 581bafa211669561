"""Imperfect camera poses: stated pose uncertainty, the joint refinement (bundle.py) and its wiring."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

import monovisual3d as mv
from monovisual3d.bench.accuracy import conditions
from monovisual3d.camera import Camera
from monovisual3d.cli import app
from monovisual3d.errors import InputError
from monovisual3d.frames import invert_transform, look_at, transform_points
from monovisual3d.geometry.sphere import predict_sphere_boxes, sphere_bbox
from monovisual3d.methods.bayes import BayesConfig
from monovisual3d.methods.bayes._kernels import score_hypotheses
from monovisual3d.methods.bayes.bundle import bundle_adjust, correction_transform, grouped_jacobian
from monovisual3d.methods.bayes.likelihood import pose_sigma_px, view_scores
from monovisual3d.methods.bayes.refine import Observation, refine_sphere
from monovisual3d.methods.bayes.sensor import SensorModel, cell_shift_px, gate_widening_px
from monovisual3d.session import Detection, Session, View, Workspace
from monovisual3d.sim.noise import perturb_pose

CAM = Camera.from_hfov(640, 480, 69.0)
TARGET = np.array([0.7, 0.0, 0.5])
WS = Workspace(np.array([0.45, -0.3, 0.2]), np.array([1.0, 0.3, 0.8]))
POSES = [
    look_at(TARGET + [-0.5, 0, 0], TARGET),
    look_at(TARGET + [-0.45, 0.15, -0.15], TARGET),
    look_at(TARGET + [-0.45, -0.15, 0.15], TARGET),
]
#: Six fruit in two rows, all visible and apart in every view.
CENTRES = np.array(
    [[0.68, -0.12, 0.58], [0.72, 0.0, 0.60], [0.66, 0.12, 0.57], [0.74, -0.11, 0.42], [0.69, 0.01, 0.40], [0.73, 0.12, 0.43]]
)
RADII = np.array([0.035, 0.028, 0.04, 0.03, 0.038, 0.025])
#: The stated uncertainty of the arm: 2 mm and 0.5 degrees per axis (1 sigma).
SIGMA_P, SIGMA_R = 0.002, np.radians(0.5)
#: The test's boxes are exact: the honest sensor model states little box noise.
EXACT_BOXES = SensorModel(alpha=0.0, sigma0_px=0.5)


def reported_poses(rotvec_view1: np.ndarray) -> list[np.ndarray]:
    """The true poses, except view 1 reported with a rotation error (about its optical axes, as the simulator does)."""
    out = [T.copy() for T in POSES]
    out[1][:3, :3] = POSES[1][:3, :3] @ Rotation.from_rotvec(rotvec_view1).as_matrix()
    return out


def session(reported: list[np.ndarray]) -> Session:
    views = []
    for T_true, T_rep in zip(POSES, reported):
        boxes = sphere_bbox(CAM, T_true, CENTRES, RADII)  # the image comes from the true pose
        views.append(View(T_rep, tuple(Detection(b) for b in boxes)))
    return Session(CAM, tuple(views), WS)


def mean_error(positions: np.ndarray) -> float:
    return float(np.mean([np.min(np.linalg.norm(positions - c, axis=1)) for c in CENTRES]))


@pytest.fixture(scope="module")
def rotated_view() -> tuple[np.ndarray, list[np.ndarray]]:
    """View 1 reported 1 degree off about its optical y axis (2 sigma of the stated uncertainty): 8 px of image shift."""
    e = np.radians([0.0, 1.0, 0.0])
    return e, reported_poses(e)


# ---------------------------------------------------------------- pose noise in pixels


def test_pose_sigma_px_is_the_projected_uncertainty_in_quadrature():
    f = CAM.fx
    assert_allclose(pose_sigma_px(CAM, np.array([0.25, 0.5, 1.0]), 0.0, 0.01), f * 0.01, rtol=1e-12)
    assert_allclose(pose_sigma_px(CAM, np.array([0.25, 0.5]), 0.002, 0.0), f * 0.002 / np.array([0.25, 0.5]), rtol=1e-12)
    assert_allclose(pose_sigma_px(CAM, 0.5, 0.003, 0.008), f * np.hypot(0.003 / 0.5, 0.008), rtol=1e-12)
    assert pose_sigma_px(CAM, np.zeros((2, 3)), 0.0, 0.0).shape == (2, 3)


def test_kernel_with_pose_noise_matches_the_numpy_reference():
    rng = np.random.default_rng(3)
    centres = TARGET + rng.uniform(-0.15, 0.15, (300, 3))
    radii = np.geomspace(0.01, 0.08, 6)
    Tob = [invert_transform(T) for T in POSES]
    boxes = [sphere_bbox(CAM, T, CENTRES, RADII) for T in POSES]
    avail = [np.ones(len(b), bool) for b in boxes]
    model, blur = SensorModel(), 0.01
    total, n_assoc, _ = score_hypotheses(
        CAM, Tob, boxes, avail, centres, radii, model, blur, CAM.fx * SIGMA_R, position_sigma=SIGMA_P
    )
    ref = np.zeros_like(total)
    for T, b, a in zip(Tob, boxes, avail):
        p = transform_points(T, centres)
        pred, vis = predict_sphere_boxes(CAM, p, radii)
        pose = pose_sigma_px(CAM, p[:, 2:3], SIGMA_P, SIGMA_R)
        extra = np.hypot(CAM.fx * blur / p[:, 2:3], pose)
        # the gate: 3 sigmas of the pose noise plus the cell's bounded shift (the cell blurs the score only)
        gate = gate_widening_px(model, pred, pose, cell_shift_px(CAM, pred, p[:, 2:3], blur))
        ref += view_scores(pred, vis, b, a, model, CAM.width, CAM.height, extra, gate)[0]
    assert_allclose(total, ref, atol=1e-6)


# ---------------------------------------------------------------- configuration


def test_config_rejects_negative_or_nan_pose_sigma():
    with pytest.raises(InputError, match="pose_sigma_mm"):
        BayesConfig(pose_sigma_mm=-1.0)
    with pytest.raises(InputError, match="pose_sigma_deg"):
        BayesConfig(pose_sigma_deg=float("nan"))
    assert BayesConfig(pose_sigma_mm=2.0).pose_position_sigma == pytest.approx(0.002)
    assert BayesConfig(pose_sigma_deg=0.5).pose_rotation_sigma == pytest.approx(np.radians(0.5))


def test_sigma_zero_is_the_exact_pose_method_unchanged():
    s = session(POSES)
    a = mv.localize(s)
    b = mv.localize(s, pose_sigma_mm=0.0, pose_sigma_deg=0.0)
    assert len(a.objects) == len(b.objects) == 6
    for oa, ob in zip(a.objects, b.objects):
        assert np.array_equal(oa.position, ob.position) and oa.radius == ob.radius and oa.score == ob.score
        assert np.array_equal(oa.covariance, ob.covariance) and oa.associations == ob.associations
        assert "pose_corrected" not in ob.extra
    assert b.pose_corrections == [] and "bundle" not in b.timing_s
    assert mean_error(a.positions) < 1e-3


def test_exact_poses_with_stated_uncertainty_estimate_no_correction():
    s = session(POSES)
    exact = mv.localize(s)
    r = mv.localize(s, pose_sigma_mm=2.0, pose_sigma_deg=0.5)
    assert len(r.objects) == 6
    assert mean_error(r.positions) < 1e-3
    assert_allclose(np.sort(r.positions, axis=0), np.sort(exact.positions, axis=0), atol=5e-4)
    pcs = r.pose_corrections
    assert [pc["view"] for pc in pcs] == [0, 1, 2]
    for pc, T in zip(pcs, POSES):
        assert np.linalg.norm(pc["rotvec_optical_rad"]) < np.radians(0.02)
        assert np.linalg.norm(pc["translation_optical_m"]) < 2e-4
        assert_allclose(np.asarray(pc["T_base_optical_corrected"]), T, atol=5e-4)
        assert all(s > 0 for s in pc["std_rotvec_optical_rad"] + pc["std_translation_optical_m"])
    json.loads(r.to_json())  # the corrections are JSON-ready


# ---------------------------------------------------------------- the joint refinement


def per_object_and_joint(reported: list[np.ndarray], model: SensorModel):
    """Each fruit refined alone (with the pose noise in its edge noise, as the method does before the joint step), then jointly."""
    Tob = [invert_transform(T) for T in reported]
    s = session(reported)
    start = CENTRES + 0.003
    alone = []
    for i in range(len(CENTRES)):
        obs = [
            Observation(
                T, v.detections[i].bbox_xyxy, None, float(pose_sigma_px(CAM, T[2, :3] @ start[i] + T[2, 3], SIGMA_P, SIGMA_R))
            )
            for T, v in zip(Tob, s.views)
        ]
        alone.append(refine_sphere(CAM, obs, start[i], RADII[i], model).centre)
    pairs = [
        (i, v, Observation(T, view.detections[i].bbox_xyxy)) for v, (T, view) in enumerate(zip(Tob, s.views)) for i in range(6)
    ]
    joint = bundle_adjust(CAM, pairs, np.array(alone), RADII, model, position_sigma=SIGMA_P, rotation_sigma=SIGMA_R)
    return np.array(alone), joint


def test_joint_refinement_recovers_fruit_and_the_rotation_of_a_view(rotated_view):
    e, reported = rotated_view
    alone, joint = per_object_and_joint(reported, EXACT_BOXES)
    err_alone = np.linalg.norm(alone - CENTRES, axis=1).mean()
    err_joint = np.linalg.norm(joint.centres - CENTRES, axis=1).mean()
    assert err_alone > 6e-3  # the shift of view 1 (8 px, ~9 mm at 0.5 m) drags every fruit
    assert err_joint < 0.6 * err_alone
    assert joint.success
    # only the views' relative rotation is observable (a common rotation of all views moves the fruit
    # with them), so compare view 1's correction with the others' mean
    w = joint.rotvec_optical
    relative = w[1] - w[[0, 2]].mean(axis=0)
    assert np.linalg.norm(relative - e) < 0.35 * np.linalg.norm(e)
    assert relative @ e / (np.linalg.norm(relative) * np.linalg.norm(e)) > 0.95
    # the corrected pose of view 1 is closer to the truth than the reported one
    T1 = joint.T_corrected_reported(1) @ invert_transform(reported[1])
    angle = lambda T: Rotation.from_matrix(T[:3, :3] @ POSES[1][:3, :3]).magnitude()  # noqa: E731  (T is T_optical_base)
    assert angle(T1) < angle(invert_transform(reported[1]))


def test_joint_covariance_is_symmetric_positive_definite(rotated_view):
    _, reported = rotated_view
    _, joint = per_object_and_joint(reported, SensorModel())
    assert joint.covariances.shape == (6, 3, 3)
    for C in joint.covariances:
        assert_allclose(C, C.T, rtol=1e-9, atol=1e-15)
        assert np.all(np.linalg.eigvalsh(C) > 0)
    assert np.all(joint.radius_std > 0)
    # uncertain poses make the fruit less certain than exact poses (sigma 0: no pose unknowns) would
    pairs = [
        (i, v, Observation(invert_transform(T), sphere_bbox(CAM, T, CENTRES[i], RADII[i])))
        for v, T in enumerate(POSES)
        for i in range(6)
    ]
    uncertain = bundle_adjust(CAM, pairs, CENTRES, RADII, SensorModel(), position_sigma=SIGMA_P, rotation_sigma=SIGMA_R)
    certain = bundle_adjust(CAM, pairs, CENTRES, RADII, SensorModel(), position_sigma=0.0, rotation_sigma=0.0)
    assert_allclose(certain.centres, CENTRES, atol=1e-6)
    assert np.all(certain.pose_std == 0) and np.all(certain.rotvec_optical == 0)
    assert np.all(np.trace(uncertain.covariances, axis1=1, axis2=2) > 1.2 * np.trace(certain.covariances, axis1=1, axis2=2))
    assert joint.pose_std.shape == (3, 6) and np.all(joint.pose_std[:, :3] < SIGMA_R) and np.all(joint.pose_std[:, 3:] < SIGMA_P)


def test_localize_with_stated_uncertainty_on_a_rotated_view(rotated_view):
    e, reported = rotated_view
    s = session(reported)
    r = mv.localize(s, alpha=0.0, sigma0_px=0.5, pose_sigma_mm=2.0, pose_sigma_deg=0.5)
    assert len(r.objects) == 6 and "poses" in r.timing_s
    for o in r.objects:
        assert o.extra["pose_corrected"]
        assert_allclose(o.covariance, o.covariance.T, rtol=1e-9, atol=1e-15)
        assert np.all(np.linalg.eigvalsh(o.covariance) > 0)
    w = np.array([pc["rotvec_optical_rad"] for pc in r.pose_corrections])
    assert np.linalg.norm(w[1] - w[[0, 2]].mean(axis=0) - e) < 0.35 * np.linalg.norm(e)
    assert mean_error(r.positions) < 5e-3
    # the same honest sensor model without the stated pose uncertainty: the search's hypotheses reject view 1's shifted
    # boxes and miss fruit; the second look then fits those from their boxes left free (view 1's edges at the robust
    # fit's floors), near the truth again
    search_only = mv.localize(s, alpha=0.0, sigma0_px=0.5, second_look=False)
    assert len(search_only.objects) < 6 and mean_error(search_only.positions) > 2 * mean_error(r.positions)
    without = mv.localize(s, alpha=0.0, sigma0_px=0.5)
    assert len(without.objects) == 6 and mean_error(without.positions) < 5e-3


def test_correction_undoes_the_simulators_pose_error():
    # perturb_pose reports [R exp([e]x), p + d]; the correction (w, t) = (e, R^T d) maps it back
    T_true = POSES[2]
    T_rep = perturb_pose(T_true, 0.004, 0.02, rng=7)
    g = np.random.default_rng(7).standard_normal(6)
    d, e = 0.004 * g[:3], 0.02 * g[3:]
    T = correction_transform(e, T_true[:3, :3].T @ d)
    assert_allclose(T @ invert_transform(T_rep), invert_transform(T_true), atol=1e-12)
    assert_allclose(correction_transform(np.zeros(3), np.zeros(3)), np.eye(4))


def test_grouped_jacobian_matches_column_by_column_differences():
    # rows 0-1 depend on object 0 (cols 0, 1) and view 0 (col 4); rows 2-3 on object 1 (cols 2, 3) and view 1 (col 5);
    # row 4 (a prior) on col 4 only
    def f(x):
        return np.array(
            [np.sin(x[0] * x[4]) + x[1] ** 2, x[0] * x[1] * np.exp(x[4]), np.cos(x[2]) * x[5], x[3] / (1 + x[5] ** 2), 3 * x[4]]
        )

    obj = np.array([0, 0, 1, 1, -1])
    view = np.array([4, 4, 5, 5, 4])
    owners = [np.where(obj >= 0, 2 * obj + k, -1) for k in range(2)] + [view]
    x = np.random.default_rng(0).uniform(-1, 1, 6)
    J = grouped_jacobian(f, x, owners, 6)
    h = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(x))
    ref = np.stack([(f(x + h[c] * np.eye(6)[c]) - f(x)) / h[c] for c in range(6)], axis=1)
    assert_allclose(J, ref, atol=1e-12)
    assert_allclose(J[4], [0, 0, 0, 0, 3, 0], atol=1e-6)


def test_bundle_rejects_bad_input():
    ob = Observation(invert_transform(POSES[0]), sphere_bbox(CAM, POSES[0], CENTRES[0], RADII[0]))
    with pytest.raises(InputError, match="observations"):
        bundle_adjust(CAM, [], CENTRES[:1], RADII[:1], SensorModel(), position_sigma=SIGMA_P, rotation_sigma=SIGMA_R)
    with pytest.raises(InputError, match="rotation_sigma"):
        bundle_adjust(CAM, [(0, 0, ob)], CENTRES[:1], RADII[:1], SensorModel(), position_sigma=SIGMA_P, rotation_sigma=-1.0)
    with pytest.raises(InputError, match="radii0"):
        bundle_adjust(CAM, [(0, 0, ob)], CENTRES[:2], RADII[:1], SensorModel(), position_sigma=SIGMA_P, rotation_sigma=SIGMA_R)
    with pytest.raises(InputError, match="object indices"):
        bundle_adjust(CAM, [(3, 0, ob)], CENTRES[:1], RADII[:1], SensorModel(), position_sigma=SIGMA_P, rotation_sigma=SIGMA_R)


# ---------------------------------------------------------------- wiring: benchmark and CLI


def test_pose_error_condition_states_the_uncertainty_to_bayes_only():
    cond = next(c for c in conditions(quick=True) if c.name == "pose-error")
    assert cond.method_options("bayes")["pose_sigma_mm"] == pytest.approx(cond.noise.pose_position_std * 1e3)
    assert cond.method_options("bayes+masks")["pose_sigma_deg"] == pytest.approx(np.degrees(cond.noise.pose_rotation_std))
    assert "pose_sigma_mm" not in cond.method_options("paper")
    clean = next(c for c in conditions(quick=True) if c.name == "paper-clean")
    assert "pose_sigma_mm" not in clean.method_options("bayes")


def test_cli_passes_pose_sigma_to_bayes_only(tmp_path):
    path = tmp_path / "s.json"
    poses = POSES
    views = [
        {"pose": {"matrix": T.tolist()}, "detections": [{"bbox_xyxy": sphere_bbox(CAM, T, CENTRES[1], RADII[1]).tolist()}]}
        for T in poses
    ]
    path.write_text(
        json.dumps({"camera": CAM.to_dict(), "views": views, "workspace": {"min": WS.min.tolist(), "max": WS.max.tolist()}})
    )
    runner = CliRunner()
    res = runner.invoke(app, ["localize", str(path), "--pose-sigma-mm", "2", "--pose-sigma-deg", "0.5", "-q"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert out["config"]["pose_sigma_mm"] == 2.0 and len(out["pose_corrections"]) == 3
    res = runner.invoke(app, ["localize", str(path), "--method", "paper", "--pose-sigma-mm", "2", "-q"])
    assert res.exit_code == 2 and "--pose-sigma-mm: not an option of --method paper (it applies to --method bayes)" in res.stderr


def test_cli_accept_sets_the_acceptance_score(tmp_path):
    path = tmp_path / "s.json"
    views = [
        {"pose": {"matrix": T.tolist()}, "detections": [{"bbox_xyxy": sphere_bbox(CAM, T, CENTRES[1], RADII[1]).tolist()}]}
        for T in POSES
    ]
    path.write_text(json.dumps({"camera": CAM.to_dict(), "views": views}))
    runner = CliRunner()
    res = runner.invoke(app, ["localize", str(path), "--accept", "12", "-q"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert out["config"]["accept"] == 12.0 and len(out["objects"]) == 1
    score = out["objects"][0]["score"]
    # above the fruit's own score nothing is reported (with a warning line after the output, not an error)
    res = runner.invoke(app, ["localize", str(path), "--accept", f"{score + 1:.3f}", "-q"])
    assert res.exit_code == 0 and json.loads(res.stdout)["objects"] == []
    assert "objects scoring below accept=" in res.stderr
    res = runner.invoke(app, ["localize", str(path), "--method", "paper", "--accept", "12", "-q"])
    assert res.exit_code == 2 and "--accept: not an option of --method paper" in res.stderr
    res = runner.invoke(app, ["localize", str(path), "--accept", "nan", "-q"])
    assert res.exit_code == 2 and "--accept: got nan, expected a finite number of nats" in res.stderr
