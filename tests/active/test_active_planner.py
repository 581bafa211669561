"""The next-best-view planner: information, occlusion by known fruit, reach, determinism, stopping rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d import Camera
from monovisual3d.active import CapSpec, PlannerConfig, PlannerState, cap_poses, ellipsoid95_mm, plan_from_state, plan_next_view
from monovisual3d.active.information import boxes_and_jacobians, occlusion_by_known
from monovisual3d.errors import InputError
from monovisual3d.frames import invert_transform, look_at
from monovisual3d.geometry.sphere import predict_sphere_boxes as predict_boxes
from monovisual3d.methods.bayes.sensor import SensorModel
from monovisual3d.result import DetectedObject
from monovisual3d.session import Detection, View, Workspace

TARGET = np.array([0.6, 0.0, 0.45])
WS = Workspace(TARGET - 0.2, TARGET + 0.2)


@pytest.fixture
def camera() -> Camera:
    return Camera.from_hfov(640, 480, 69.0)


def view_of(camera: Camera, T: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> View:
    """A view with the exact predicted box of every sphere, in the given order."""
    boxes, _ = predict_boxes(camera, (invert_transform(T)[:3, :3] @ centres.T).T + invert_transform(T)[:3, 3], radii[:, None])
    return View(T, tuple(Detection(b[0]) for b in boxes))


def obj(c: np.ndarray, r: float, assoc: dict[int, int], std_m: float = 0.003) -> DetectedObject:
    return DetectedObject(np.asarray(c, float), 10.0, r, np.eye(3) * std_m**2, assoc)


def angle_deg(a: np.ndarray, b: np.ndarray, centre: np.ndarray) -> float:
    u, v = a - centre, b - centre
    return math.degrees(math.acos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1)))


def test_jacobian_matches_finite_differences_of_predict_boxes(camera: Camera) -> None:
    T = look_at([0.1, 0.05, 0.5], TARGET)
    c = np.array([[0.62, 0.03, 0.44]])
    r = np.array([0.03])
    boxes, J, vis, depth = boxes_and_jacobians(camera, invert_transform(T)[None], c, r)
    T_ob = invert_transform(T)
    h = 1e-4
    for k in range(4):
        dc, dr = np.zeros(3), 0.0
        if k < 3:
            dc[k] = h
        else:
            dr = h
        bp, _ = predict_boxes(camera, ((c + dc) @ T_ob[:3, :3].T) + T_ob[:3, 3], np.array([[r[0] + dr]]))
        bm, _ = predict_boxes(camera, ((c - dc) @ T_ob[:3, :3].T) + T_ob[:3, 3], np.array([[r[0] - dr]]))
        assert_allclose(J[0, 0, :, k], (bp[0, 0] - bm[0, 0]) / (2 * h), rtol=1e-3, atol=1e-2)
    assert vis[0, 0] and depth[0, 0] > 0


def test_fruit_seen_in_one_view_is_looked_at_from_another_angle(camera: Camera) -> None:
    fruit = np.array([[0.6, 0.05, 0.45]])
    T0 = look_at([0.1, 0.0, 0.45], TARGET)
    state = PlannerState(camera, (view_of(camera, T0, fruit, np.array([0.03])),), (), WS)
    # candidates: the same direction (closer), and a cap of other angles
    same = look_at(T0[:3, 3] + 0.1 * (TARGET - T0[:3, 3]) / 0.5, TARGET)
    cands = np.concatenate([same[None], cap_poses(CapSpec(n=30), TARGET)])
    plan = plan_from_state(state, cands)
    assert plan.unexplained == [(0, 0)]
    assert plan.index != 0
    assert angle_deg(plan.poses[0][:3, 3], T0[:3, 3], fruit[0]) > 20.0
    # the tentative object's gain grows with the angle to the first view
    g = plan.target_gains[:, 0]
    assert g[0] < np.median(g[1:])


def hidden_setup(camera: Camera) -> tuple[PlannerState, np.ndarray]:
    """Fruit A in front of fruit B along base +x; both localised from two side views."""
    a, b = np.array([0.45, 0.0, 0.45]), np.array([0.65, 0.0, 0.45])
    C = np.stack([a, b])
    R = np.array([0.04, 0.03])
    T1 = look_at([0.55, -0.45, 0.55], [0.55, 0.0, 0.45])
    T2 = look_at([0.55, 0.45, 0.35], [0.55, 0.0, 0.45])
    views = (view_of(camera, T1, C, R), view_of(camera, T2, C, R))
    objects = (obj(a, 0.04, {0: 0, 1: 0}), obj(b, 0.03, {0: 1, 1: 1}))
    hidden = look_at([0.05, 0.0, 0.45], b)  # looks along a -> b: B's disc lies inside A's
    open_ = look_at([0.3, 0.3, 0.8], b)
    return PlannerState(camera, views, objects, WS), np.stack([hidden, open_])


def test_fruit_hidden_behind_known_fruit_gains_nothing_there(camera: Camera) -> None:
    state, cands = hidden_setup(camera)
    plan = plan_from_state(state, cands)
    assert plan.unexplained == []
    gains = plan.target_gains
    assert gains[0, 1] == 0.0  # B hidden behind A in candidate 0
    assert gains[0, 0] > 0.0  # A itself is seen there
    assert gains[1, 1] > 0.0  # and B is seen from the open candidate


def test_occlusion_by_known_fruit_reference_cases() -> None:
    # disc 1 entirely behind the larger, nearer disc 0; disc 2 far to the side
    boxes = np.array([[[100, 100, 200, 200], [130, 130, 170, 170], [400, 100, 440, 140]]], float)
    depth = np.array([[0.4, 0.6, 0.5]])
    edge, frac = occlusion_by_known(boxes, depth)
    assert_allclose(frac[0], [1.0, 0.0, 1.0])
    assert_allclose(edge[0, 1], 0.0)
    assert edge.shape == (1, 3, 4)


def test_candidates_outside_reach_are_never_picked(camera: Camera) -> None:
    state, _ = hidden_setup(camera)
    cands = cap_poses(CapSpec(n=40), TARGET)
    dist = np.linalg.norm(cands[:, :3, 3], axis=1)
    reach = float(np.median(dist))
    n_in = int((dist <= reach).sum())
    plan = plan_from_state(state, cands, count=n_in, config=PlannerConfig(reach_m=reach))
    assert all(dist[i] <= reach for i in plan.indices)
    assert np.all(np.isneginf(plan.scores[dist > reach]))
    with pytest.raises(InputError, match="count: got .*only .* reachable"):
        plan_from_state(state, cands, count=n_in + 1, config=PlannerConfig(reach_m=reach))


def test_cap_reach_filter_and_spec() -> None:
    full = cap_poses(CapSpec(n=50), TARGET)
    kept = cap_poses(CapSpec(n=50, reach_m=0.8), TARGET)
    assert len(kept) < len(full)
    assert np.all(np.linalg.norm(kept[:, :3, 3], axis=1) <= 0.8)
    d = np.linalg.norm(full[:, :3, 3] - TARGET, axis=1)
    assert d.min() >= 0.4 - 1e-9 and d.max() <= 0.6 + 1e-9
    # every camera looks at the target
    to_t = (TARGET - full[:, :3, 3]) / d[:, None]
    assert_allclose(np.einsum("ni,ni->n", to_t, full[:, :3, 2]), 1.0, atol=1e-9)
    spec = CapSpec.parse("cap:12:distance=0.3..0.5:azimuth=-30..30:elevation=0..20:reach=1.2")
    assert spec == CapSpec(12, (0.3, 0.5), (-30.0, 30.0), (0.0, 20.0), 1.2)


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("cap:10:distance=0.6..0.4", "distance: got 0.6..0.4"),
        ("cap:10:azimuth=-200..0", "azimuth: got -200..0"),
        ("cap:10:elevation=0..x", "elevation: got '0..x'"),
        ("cap:0", "N: got 0"),
        ("cap:ten", "N an integer"),
        ("cap:10:tilt=1..2", "unknown key 'tilt'"),
        ("cap:10:reach=-1", "reach: got -1"),
        ("sphere:10", "expected cap:N"),
    ],
)
def test_bad_cap_specs_are_rejected(spec: str, match: str) -> None:
    with pytest.raises(InputError, match=match):
        CapSpec.parse(spec)


def test_ranking_is_deterministic_and_ties_go_to_the_lower_index(camera: Camera) -> None:
    state, _ = hidden_setup(camera)
    cands = cap_poses(CapSpec(n=25), TARGET)
    p1 = plan_from_state(state, cands, count=3)
    p2 = plan_from_state(state, cands, count=3)
    assert_array_equal(p1.ranking, p2.ranking)
    assert_array_equal(p1.scores, p2.scores)
    assert p1.indices == p2.indices
    assert p1.ranking[0] == p1.index
    assert np.all(np.diff(p1.scores[p1.ranking]) <= 0)
    dup = np.concatenate([cands[[p1.index]], cands])  # the best candidate twice: index 0 and p1.index + 1
    p3 = plan_from_state(state, dup)
    assert p3.index == 0 and p3.ranking[1] == p1.index + 1


def test_batch_picks_distinct_views_with_diminishing_gains(camera: Camera) -> None:
    state, _ = hidden_setup(camera)
    cands = cap_poses(CapSpec(n=30), TARGET)
    plan = plan_from_state(state, cands, count=4)
    assert len(set(plan.indices)) == 4 and plan.poses.shape == (4, 4, 4)
    assert plan.gains[0] >= plan.gains[-1]
    d = plan.to_dict()
    assert d["indices"] == list(plan.indices) and len(d["poses"]) == 4 and d["index"] == plan.indices[0]


def test_motion_weight_prefers_nearby_views(camera: Camera) -> None:
    state, _ = hidden_setup(camera)
    cands = cap_poses(CapSpec(n=40), TARGET)
    current = state.views[-1].T_base_optical[:3, 3]
    free = plan_from_state(state, cands)
    costly = plan_from_state(state, cands, config=PlannerConfig(motion_weight=500.0))
    d = np.linalg.norm(cands[:, :3, 3] - current, axis=1)
    assert d[costly.index] <= d[free.index]
    assert np.all(costly.components["motion"] >= 0)


def test_stopping_rule(camera: Camera) -> None:
    state, cands = hidden_setup(camera)
    tight = PlannerState(camera, state.views, tuple(obj(o.position, o.radius, o.associations, 0.0005) for o in state.objects), WS)
    # boxes exact to 0.05 px: the two views support the tight covariance
    exact = PlannerConfig(box_noise=0.0, sensor=SensorModel(sigma0_px=0.05))
    assert plan_from_state(tight, cands, config=exact).done
    # the same covariance with boxes known to 5 %: two views of such boxes cannot support it, so not done
    plan = plan_from_state(tight, cands, config=PlannerConfig(box_noise=0.05))
    assert not plan.done and np.all(plan.ellipsoid_mm > 5.0)
    loose = PlannerState(camera, state.views, tuple(obj(o.position, o.radius, o.associations, 0.005) for o in state.objects), WS)
    assert not plan_from_state(loose, cands).done
    # an unexplained box keeps it going even when every object is precise
    extra = View(state.views[0].T_base_optical, state.views[0].detections + (Detection(np.array([10.0, 10.0, 40.0, 40.0])),))
    pending = PlannerState(camera, (extra, state.views[1]), tight.objects, WS)
    plan = plan_from_state(pending, cands, config=exact)
    assert not plan.done and plan.unexplained == [(0, 2)]
    assert_allclose(ellipsoid95_mm(np.eye(3) * 1e-6), 1e3 * math.sqrt(7.814727903251178) * 1e-3)


def test_empty_session_picks_the_view_covering_the_workspace(camera: Camera) -> None:
    cands = np.stack([look_at([0.1, 0.0, 0.45], TARGET), look_at([0.1, 0.0, 0.45], TARGET + [0.0, 0.9, 0.0])])
    plan = plan_from_state(PlannerState(camera, (), (), WS), cands)
    assert plan.index == 0 and plan.components["coverage"][0] > plan.components["coverage"][1]
    assert not plan.done
    with pytest.raises(InputError, match="workspace"):
        plan_from_state(PlannerState(camera, (), (), None), cands)


def test_bad_planner_input_is_rejected(camera: Camera) -> None:
    state, cands = hidden_setup(camera)
    with pytest.raises(InputError, match="empty list"):
        plan_from_state(state, np.zeros((0, 4, 4)))
    bad = cands.copy()
    bad[1, 0, 0] = 2.0
    with pytest.raises(InputError, match=r"candidates\[1\]: rotation block is not orthonormal"):
        plan_from_state(state, bad)
    with pytest.raises(InputError, match="count: got 0"):
        plan_from_state(state, cands, count=0)
    with pytest.raises(InputError, match="p_occluder: got 1.5"):
        PlannerConfig(p_occluder=1.5)
    with pytest.raises(InputError, match="session_or_localizer"):
        plan_next_view(42, cands)


def test_plan_next_view_with_a_localizer(camera: Camera) -> None:
    from monovisual3d.methods.bayes import BayesLocalizer

    state, cands = hidden_setup(camera)
    loc = BayesLocalizer(camera, workspace=WS)
    for v in state.views:
        loc.update(v)
    plan = plan_next_view(loc, cands, objects=list(state.objects))
    assert plan.index in (0, 1) and plan.target_gains.shape == (2, 2)


def _simulated_state(box_sigma: float, n_views: int) -> PlannerState:
    from monovisual3d.active.loop import fixed_sequence
    from monovisual3d.methods.bayes import BayesLocalizer
    from monovisual3d.sim import default_camera, paper_scene
    from monovisual3d.sim.noise import NoiseModel
    from monovisual3d.sim.scenes import scene_target
    from monovisual3d.sim.simulate import simulate

    scene, cam = paper_scene(), default_camera()
    session, _ = simulate(scene, cam, fixed_sequence(scene_target(scene), n_views), noise=NoiseModel(box_sigma=box_sigma), rng=3)
    loc = BayesLocalizer(cam)
    for v in session.views:
        loc.update(v)
    return PlannerState(cam, session.views, tuple(loc.estimate()), None)


@pytest.mark.parametrize(("box_sigma", "low", "high"), [(0.0, 0.01, 0.01), (0.03, 0.022, 0.045)])
def test_auto_box_noise_follows_the_boxes(box_sigma: float, low: float, high: float) -> None:
    """Edge noise of the simulator: sqrt(1.25) * box_sigma of the size; exact boxes give the 1 % floor."""
    from monovisual3d.active.targets import estimate_box_noise

    alpha = estimate_box_noise(_simulated_state(box_sigma, 5), PlannerConfig())
    assert alpha is not None and low <= alpha <= high


def test_auto_box_noise_needs_enough_edges(camera: Camera) -> None:
    from monovisual3d.active.targets import estimate_box_noise

    state, _ = hidden_setup(camera)  # 2 objects x 2 views: 16 edges, 8 parameters: 8 left, enough
    assert estimate_box_noise(state, PlannerConfig()) == pytest.approx(0.01)  # exact boxes: the floor
    one = PlannerState(
        camera, state.views[:1], tuple(obj(o.position, o.radius, {0: o.associations[0]}) for o in state.objects), WS
    )
    assert estimate_box_noise(one, PlannerConfig()) is None  # 8 edges, 8 parameters
    with pytest.raises(InputError, match="box_noise: got 'often', expected a fraction >= 0 or 'auto'"):
        PlannerConfig(box_noise="often")


def test_coverage_visibility_honours_lens_distortion() -> None:
    """A point the pinhole model puts outside the image is seen through a barrel lens (Camera's projection)."""
    from monovisual3d.active.information import sees

    p_base = np.array([[0.7, 0.0, 1.0]])  # pinhole: u = 320 + 500 * 0.7 = 670 > 640
    barrel = Camera(640, 480, 500.0, 500.0, 320.0, 240.0, "plumb_bob", (-0.2, 0.0, 0.0, 0.0))
    pinhole = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    T_optical_base = np.eye(4)[None]
    assert barrel.project(p_base)[0, 0] < 640 < pinhole.project(p_base)[0, 0]
    assert_array_equal(sees(barrel, T_optical_base, p_base), [[True]])
    assert_array_equal(sees(pinhole, T_optical_base, p_base), [[False]])
    assert_array_equal(sees(pinhole, T_optical_base, np.array([[0.0, 0.0, 0.01]])), [[False]])  # too close to the lens
