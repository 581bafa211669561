"""The ``bayes`` shape stage's occlusion refit: edges a nearer object cuts are censored, not fitted as full edges."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

import monovisual3d as mv
from monovisual3d.camera import Camera
from monovisual3d.frames import invert_transform, look_at
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.methods.bayes import shapes
from monovisual3d.methods.bayes.box_sides import boxes_near, covered_sides, occluded_edges, spans
from monovisual3d.methods.bayes.occlusion import OCCLUSION_MARGIN_SIGMAS, _predicted, _view_flags, _whole_sides_pairs
from monovisual3d.methods.bayes.refine import Observation, _BoxResiduals, observation_residuals, refine_sphere
from monovisual3d.methods.bayes.sensor import SensorModel
from monovisual3d.session import Workspace
from monovisual3d.sim.scene import Scene, Sphere
from monovisual3d.sim.simulate import simulate

CAM = Camera.from_hfov(640, 480, 69.0)
TARGET = np.array([0.7, 0.0, 0.5])


def poses(d=0.5, off=0.15):
    return [
        look_at(TARGET + [-d, 0, 0], TARGET),
        look_at(TARGET + [-d + 0.05, off, -off], TARGET),
        look_at(TARGET + [-d + 0.05, -off, off], TARGET),
    ]


def test_occluded_edges_flags_only_edges_whose_extreme_point_a_nearer_silhouette_covers():
    box = np.array([0.0, 0.0, 40.0, 40.0])
    assert occluded_edges(box, np.array([[30.0, 5.0, 70.0, 35.0]])).tolist() == [False, False, True, False]
    # boxes that overlap only at a corner: the silhouettes' extreme points stay visible
    assert occluded_edges(box, np.array([[35.0, 35.0, 75.0, 75.0]])).tolist() == [False] * 4
    assert occluded_edges(box, np.zeros((0, 4))).tolist() == [False] * 4
    assert occluded_edges(box, np.array([[-10.0, -10.0, 50.0, 50.0]])).tolist() == [True] * 4
    # the right edge's extreme point (40, 20) lies 2 px inside the nearer silhouette: covered without a margin only
    rim = np.array([[38.0, 0.0, 78.0, 40.0]])
    assert occluded_edges(box, rim)[2]
    assert not occluded_edges(box, rim, np.array([[3.0, 3.0]]))[2]


def test_censored_edges_batched_equal_the_per_observation_ones():
    rng = np.random.default_rng(3)
    c, r = TARGET + rng.normal(0, 0.02, 3), 0.03
    obs = []
    for i, T in enumerate(poses()):
        b = sphere_bbox(CAM, T, c[None], r)[0] + rng.normal(0, 1.0, 4)
        b[2] -= 8.0 * (i == 0)  # cut by an occluder
        obs.append(Observation(invert_transform(T), b, censored=np.array([False, False, i == 0, False])))
    model = SensorModel()
    loop = np.concatenate(
        [observation_residuals(CAM, ob.T_optical_base[:3, :3] @ c + ob.T_optical_base[:3, 3], r, ob, model) for ob in obs]
    )
    assert loop[2] == 0.0  # the cut edge lies inside the prediction: a censored edge does not pull inward
    f = _BoxResiduals(CAM, obs, model)
    assert_allclose(f.batch_numpy(c[None], np.array([r]))[0], loop, rtol=1e-12, atol=1e-12)
    assert_allclose(f.batch(c[None], np.array([r]))[0], loop, rtol=1e-10, atol=1e-10)


def test_refit_with_the_cut_edge_censored_removes_the_occlusion_bias():
    c, r = np.array([0.72, 0.03, 0.47]), 0.031
    boxes = [sphere_bbox(CAM, T, c[None], r)[0] for T in poses()]
    cut = boxes[0].copy()
    cut[2] -= 0.15 * (cut[2] - cut[0])  # about two edge sigmas: the robust loss alone still follows it
    model = SensorModel()
    flags = np.array([False, False, True, False])
    full = [Observation(invert_transform(T), b) for T, b in zip(poses(), [cut, *boxes[1:]])]
    censored = [
        Observation(invert_transform(T), b, censored=flags if k == 0 else None)
        for k, (T, b) in enumerate(zip(poses(), [cut, *boxes[1:]]))
    ]
    biased = np.linalg.norm(refine_sphere(CAM, full, c + 0.005, r, model).centre - c)
    fixed = np.linalg.norm(refine_sphere(CAM, censored, c + 0.005, r, model).centre - c)
    assert biased > 1e-3
    assert fixed < 0.2e-3


def test_a_fruit_half_hidden_by_a_nearer_one_is_localised_better_with_the_refit(monkeypatch):
    front, back = np.array([0.62, 0.0, 0.5]), np.array([0.72, 0.05, 0.5])
    scene = Scene((Sphere(front, 0.03), Sphere(back, 0.03)), (), "two")
    views = [look_at(TARGET + [-0.5, y, 0.02 * k], TARGET + [0, y, 0]) for k, y in enumerate((-0.1, -0.05, 0.0, 0.05))]
    ws = Workspace(np.array([0.45, -0.3, 0.3]), np.array([1.0, 0.3, 0.7]))
    session, _ = simulate(scene, CAM, np.array(views), rng=0, supersample=4, workspace=ws)

    def errors():
        res = mv.localize(session)
        est = np.array([o.position for o in res.objects])
        return [float(np.min(np.linalg.norm(est - t, axis=1))) for t in (front, back)]

    with_refit = errors()
    monkeypatch.setattr(shapes, "occlusion_refit", lambda problem, objects, flags=None: objects)
    without = errors()
    assert without[1] > 3e-3  # the hidden part of its boxes pulls the fit
    assert with_refit[1] < 1e-3
    assert abs(with_refit[0] - without[0]) < 0.2e-3


def test_boxes_that_do_not_meet_widened_by_their_pads_flag_nothing():
    """``occlusion_flags`` skips the nearer boxes that ``boxes_near`` rules out: on random boxes and stds, a pair it
    rules out gets no flag from either test at the pair's margin, and a pair that overlaps is never ruled out."""
    rng = np.random.default_rng(5)
    n = 60
    corner = rng.uniform(0, 600, (n, 2))
    boxes = np.hstack([corner, corner + rng.uniform(5, 120, (n, 2))])
    boxes[3] = np.nan
    std = rng.uniform(0, 25, (n, 2))
    meets = boxes_near(boxes, OCCLUSION_MARGIN_SIGMAS * std)
    assert not meets[3].any() and not meets.diagonal().any()
    ruled_out = 0
    for i in range(n):
        for j in range(n):
            margin = OCCLUSION_MARGIN_SIGMAS * np.hypot(std[j], std[i])[None]
            overlap = np.all(boxes[i, :2] <= boxes[j, 2:]) and np.all(boxes[j, :2] <= boxes[i, 2:])
            if i == j or meets[i, j]:
                continue
            ruled_out += 1
            assert not overlap
            assert not occluded_edges(boxes[i], boxes[j][None], margin).any()
            assert not covered_sides(boxes[i], boxes[j][None], margin).any()
    assert ruled_out > n * n // 4


def test_an_edge_behind_a_tall_occluder_is_left_out_only_where_it_ends_at_that_occluder():
    """A farther container's right edge behind a nearer tall one: left out of the shape fit where the visible part's
    box ends at the occluder's left edge, kept where it lies well inside the occluder (an amodal box's own edge), even
    when a third, unrelated tall box elsewhere in the image begins at that column."""
    from types import SimpleNamespace

    problem = SimpleNamespace(model=SensorModel())
    predicted = np.array([100.0, 50, 160, 200])
    nearer = np.array([[150.0, 40, 230, 210], [190.0, 400, 250, 500]])  # both tall, both nearer
    margin, tall = np.full((2, 2), OCCLUSION_MARGIN_SIGMAS * np.hypot(1.0, 1.0)), np.array([True, True])

    def cut(observed):  # the edges either nearer box leaves out
        pairs = [np.broadcast_to(x, nearer.shape) for x in (predicted, observed)]
        return _whole_sides_pairs(problem, pairs[0], pairs[1], nearer, margin, tall).any(axis=0)

    visible_part = cut(np.array([100.0, 50, 150, 200]))
    amodal = cut(np.array([100.0, 50, 190, 200]))
    assert visible_part.tolist() == [False, False, True, False]
    assert amodal.tolist() == [False, False, False, False]


def test_predicted_boxes_and_stds_batched_equal_one_object_at_a_time():
    """``_predicted`` (all objects of a view at once) gives each object's box, depth and projected-centre std as
    the single-object formulas do: spheres, upright and lying spheroids, with and without a covariance, one behind
    the camera."""
    from monovisual3d.geometry.sphere import predict_sphere_boxes
    from monovisual3d.geometry.spheroid import predict_spheroid_boxes
    from monovisual3d.methods.bayes.config import BayesConfig
    from monovisual3d.methods.bayes.problem import Problem, ViewData
    from monovisual3d.methods.bayes.sensor import box_edge_sigma_px
    from monovisual3d.methods.bayes.state import Found

    rng = np.random.default_rng(8)
    views = tuple(ViewData(i, invert_transform(T), np.zeros((0, 4)), (), None) for i, T in enumerate(poses()))
    problem = Problem(CAM, BayesConfig(), SensorModel(), views)
    objects = []
    for i in range(12):
        learned = {} if i % 3 == 0 else {"semi_up": 0.05} if i % 3 == 1 else {"semi_up": 0.06, "axis": np.array([0.0, 1.0, 0.0])}
        a = rng.normal(size=(3, 3)) * 1e-3
        cov = a @ a.T if i % 2 else None
        objects.append(Found(TARGET + rng.normal(0, 0.1, 3), 1.0, 0.02 + 0.01 * rng.random(), cov, **learned))
    objects.append(Found(np.array([-1.0, 0.0, 0.5]), 1.0, 0.03))  # behind every camera
    for v, vd in enumerate(views):
        boxes, depth, std = _predicted(problem, objects, v)
        R, t = vd.T_optical_base[:3, :3], vd.T_optical_base[:3, 3]
        for i, o in enumerate(objects):
            p = R @ o.position + t
            if o.semi_up is not None:
                up = R @ (problem.config.up_vector if o.axis is None else o.axis)
                box = predict_spheroid_boxes(CAM, p[None], [o.radius], [o.semi_up], up)[0][0, 0]
            else:
                box = predict_sphere_boxes(CAM, p[None], np.array([o.radius]))[0][0, 0]
            assert_allclose(boxes[i], box, rtol=1e-12, atol=1e-9)
            assert_allclose(depth[i], p[2], rtol=1e-12)
            if o.covariance is not None and p[2] > 0:
                J = np.array([[CAM.fx, 0.0, -CAM.fx * p[0] / p[2]], [0.0, CAM.fy, -CAM.fy * p[1] / p[2]]]) / p[2]
                want = np.sqrt(np.diag(J @ R @ o.covariance @ R.T @ J.T))
            else:
                want = box_edge_sigma_px(problem.model, box)[:2]
            assert_allclose(std[i], want, rtol=1e-9, equal_nan=True)
        assert np.isnan(boxes[-1]).all()
    assert _predicted(problem, [], 0)[0].shape == (0, 4)


def _pair_flags(pred, observed, nearer, margin, straight, sigma):
    """The occlusion tests for one (object, nearer object) pair written edge by edge in plain Python (the reference of
    the vectorised ones): the edges whose extreme point the nearer silhouette covers, and those a shape fit leaves out."""
    x1, y1, x2, y2 = pred
    n1, n2, n3, n4 = nearer
    mx, my = margin
    if not all(np.isfinite(v) for v in (*pred, *nearer)):
        return [False] * 4, [False] * 4
    cx, cy, hx, hy = (n1 + n3) / 2, (n2 + n4) / 2, max((n3 - n1) / 2 - mx, 1e-9), max((n4 - n2) / 2 - my, 1e-9)
    points = [(x1, (y1 + y2) / 2), ((x1 + x2) / 2, y1), (x2, (y1 + y2) / 2), ((x1 + x2) / 2, y2)]
    shifted = [((px - cx) / hx) ** 2 + ((py - cy) / hy) ** 2 < 1.0 for px, py in points]
    spans_y, spans_x = n2 - my <= y1 and n4 + my >= y2, n1 - mx <= x1 and n3 + mx >= x2
    covered = [
        spans_y and n1 + mx < x1 < n3 - mx,
        spans_x and n2 + my < y1 < n4 - my,
        spans_y and n1 + mx < x2 < n3 - mx,
        spans_x and n2 + my < y2 < n4 - my,
    ]
    if straight:  # the edge must also end at the occluder's facing edge
        facing, tol = (n3, n4, n1, n2), (mx, my, mx, my)
        ok = all(np.isfinite(observed))
        covered = [c and ok and abs(f - o) <= t + 3.0 * s for c, f, o, t, s in zip(covered, facing, observed, tol, sigma)]
    return shifted, covered


def test_flags_of_all_objects_at_once_equal_the_tests_one_pair_at_a_time():
    """``_view_flags`` (every pair of a view at once) flags what the tests written edge by edge for one pair flag,
    combined over each object's nearer objects: random boxes, stds, straight occluders, objects without a box; and
    each edge it censors may be hidden as far as the farthest far side of the nearer boxes that hide it (as seen, or
    as predicted where the nearer object holds no box), widened by the pair's margin."""
    from monovisual3d.methods.bayes.box_sides import EDGE_AT_OCCLUDER_SIGMAS
    from monovisual3d.methods.bayes.config import BayesConfig
    from monovisual3d.methods.bayes.problem import Problem, ViewData
    from monovisual3d.methods.bayes.sensor import box_edge_sigma_px

    assert EDGE_AT_OCCLUDER_SIGMAS == 3.0  # as the reference writes it
    rng = np.random.default_rng(12)
    n = 40
    corner = rng.uniform(0, 500, (n, 2))
    boxes = np.hstack([corner, corner + rng.uniform(20, 160, (n, 2))])
    boxes[5] = np.nan
    observed = boxes + rng.normal(0, 4, boxes.shape)
    std, depth = rng.uniform(0, 6, (n, 2)), rng.uniform(0.5, 1.0, n)
    straight = rng.random(n) < 0.4
    assoc = [int(k) if rng.random() < 0.8 else -1 for k in range(n)]  # object k holds box k of the view, or none
    view = ViewData(0, np.eye(4), observed, (), None)
    problem = Problem(CAM, BayesConfig(), SensorModel(), (view,))
    meets = boxes_near(boxes, OCCLUSION_MARGIN_SIGMAS * std) & (depth[None, :] < depth[:, None])
    for i in range(n):  # an observed edge near a straight occluder's facing edge: both sides of the tolerance
        js = np.flatnonzero(meets[i] & straight)
        if len(js) and i % 2:
            k = int(rng.integers(4))
            sigma_k = box_edge_sigma_px(SensorModel(), observed[i])[k]
            observed[i, k] = boxes[js[0], (k + 2) % 4] + rng.uniform(-6, 6) * sigma_k
    counts = np.zeros(2, dtype=int)
    for whole in (False, True):
        shifted, censored, hidden_to = _view_flags(problem, (boxes, depth, std), meets, 0, assoc, straight, whole)
        for i in range(n):
            want_shifted, want_covered = np.zeros(4, dtype=bool), np.zeros(4, dtype=bool)
            want_to = np.array([np.inf, np.inf, -np.inf, -np.inf])
            sigma = box_edge_sigma_px(problem.model, observed[i])
            for j in np.flatnonzero(meets[i]):
                margin = OCCLUSION_MARGIN_SIGMAS * np.hypot(std[j], std[i])
                s_ij, c_ij = _pair_flags(boxes[i], observed[i], boxes[j], margin, straight[j], sigma)
                want_shifted |= s_ij
                want_covered |= c_ij
                far_side = (observed[j] if assoc[j] >= 0 else boxes[j]) + np.r_[-margin, margin]
                for k in np.flatnonzero(c_ij):
                    want_to[k] = min(want_to[k], far_side[k]) if k < 2 else max(want_to[k], far_side[k])
            assert shifted[i].tolist() == want_shifted.tolist()
            if whole and assoc[i] >= 0:
                assert censored[i].tolist() == want_covered.tolist()
                assert_allclose(hidden_to[i], np.where(want_covered, want_to, np.nan))
            elif not whole:
                assert censored[i].tolist() == want_shifted.tolist()
                assert np.isnan(hidden_to[i]).all()
            counts += [want_shifted.any(), whole and assoc[i] >= 0 and want_covered.any()]
    assert counts[0] >= 10 and counts[1] >= 3  # both tests flag edges here
    # a farther box whose right side a tall nearer box covers, its observed right edge d sigmas from the occluder's left
    pair = np.array([[100.0, 50, 160, 200], [150.0, 40, 230, 210]])
    std2, depth2 = np.full((2, 2), 0.5), np.array([1.0, 0.5])
    meets2 = boxes_near(pair, OCCLUSION_MARGIN_SIGMAS * std2) & (depth2[None, :] < depth2[:, None])
    seen = []
    for d in (0.5, 2.0, 2.5, 4.5, 6.0):
        obs = np.array([[100.0, 50, 150.0, 200], pair[1]])
        margin = OCCLUSION_MARGIN_SIGMAS * np.hypot(std2[1], std2[0])
        obs[0, 2] = 150.0 + d * box_edge_sigma_px(SensorModel(), obs[0])[2] + margin[0]
        sigma = box_edge_sigma_px(SensorModel(), obs[0])  # of the box as observed (a little wider)
        problem2 = Problem(CAM, BayesConfig(), SensorModel(), (ViewData(0, np.eye(4), obs, (), None),))
        _, cut, _ = _view_flags(problem2, (pair, depth2, std2), meets2, 0, [0, 1], np.array([False, True]), True)
        want = _pair_flags(pair[0], obs[0], pair[1], margin, True, sigma)[1]
        assert cut[0].tolist() == want
        seen.append(bool(cut[0, 2]))
    assert seen == [True, True, True, False, False]  # within 3 sigmas of the occluder's edge (plus the margin)


def test_a_nearer_box_spans_a_side_only_where_it_reaches_past_both_ends_to_within_each_edge_tolerance():
    """``spans`` is the one test that a nearer box covers a whole side; each edge has its own tolerance."""
    box = np.array([100.0, 50, 160, 200])
    nearer = np.array([[150.0, 52, 230, 199], [90.0, 40, 120, 210], [150.0, 60, 230, 210]])
    assert spans(np.broadcast_to(box, (3, 4)), nearer, 0.0).tolist() == [[False, False], [True, False], [False, False]]
    # 2 px short at the top, 1 px at the bottom: covered with 2 px of tolerance there, not with 1 px at the top
    assert spans(box, nearer[:1], [0.0, 2.0, 0.0, 1.0]).tolist() == [[True, False]]
    assert spans(box, nearer[:1], [0.0, 1.0, 0.0, 1.0]).tolist() == [[False, False]]
    # the width: a nearer box wider than the box on both sides spans it
    assert spans(box, np.array([[95.0, 0, 165, 120]]), 0.0).tolist() == [[False, True]]
