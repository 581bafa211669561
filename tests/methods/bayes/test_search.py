"""The search's explaining away (``box_dominated``) and the swap pass's gate."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import monovisual3d as mv
from monovisual3d.errors import InputError
from monovisual3d.methods.bayes import BayesConfig
from monovisual3d.methods.bayes._kernels import box_dominated_fused
from monovisual3d.methods.bayes.search import box_dominated, search


def _naive_dominated(total, assoc, margin):
    """The definition, hypothesis by hypothesis."""
    V, N, K = assoc.shape
    out = np.zeros((N, K), dtype=bool)
    for n in range(N):
        for k in range(K):
            if not np.isfinite(total[n, k]) or (assoc[:, n, k] < 0).all():
                continue
            out[n, k] = all(
                any(
                    np.isfinite(total[m, q]) and assoc[v, m, q] == assoc[v, n, k] and total[m, q] > total[n, k] + margin
                    for m in range(N)
                    for q in range(K)
                )
                for v in range(V)
                if assoc[v, n, k] >= 0
            )
    return out


@pytest.mark.parametrize("margin", [0.0, 3.0, 10.0])
def test_box_dominated_matches_its_definition(margin):
    rng = np.random.default_rng(7)
    for _ in range(20):
        V, N, K, B = 3, 12, 2, 4
        total = rng.normal(10, 6, (N, K))
        total[rng.random((N, K)) < 0.1] = -np.inf
        assoc = rng.integers(-1, B, (V, N, K)).astype(np.int16)
        got = box_dominated(total, assoc, [B] * V, margin)
        assert got.shape == (N, K) and got.dtype == bool
        np.testing.assert_array_equal(got, _naive_dominated(total, assoc, margin))
        np.testing.assert_array_equal(box_dominated_fused(total, assoc, [B] * V, margin), got)


def test_compiled_box_dominated_equals_the_numpy_reference_on_large_inputs():
    """Many hypotheses sharing few boxes, unscored ones, views without boxes, no margin and an infinite one."""
    rng = np.random.default_rng(11)
    V, N, K = 4, 3000, 7
    n_boxes = [40, 0, 25, 3]
    total = rng.normal(12, 8, (N, K))
    total[rng.random((N, K)) < 0.3] = -np.inf
    total[0, 0], total[1, 1], total[2, 2] = np.inf, np.nan, -np.inf  # not scored, for the reference
    assoc = np.stack([rng.integers(-1, max(b, 1), (N, K)) if b else np.full((N, K), -1) for b in n_boxes]).astype(np.int16)
    for margin in (0.0, 6.0, np.inf):
        ref = box_dominated(total, assoc, n_boxes, margin)
        assert 0 < ref.sum() < ref.size or margin == np.inf
        assert_array_equal(box_dominated_fused(total, assoc, n_boxes, margin), ref)
    empty = np.zeros((0, K))
    assert box_dominated_fused(empty, np.zeros((V, 0, K), dtype=np.int16), n_boxes, 10.0).shape == (0, K)


def test_box_dominated_never_drops_the_best_user_of_a_box_and_inf_drops_nothing():
    rng = np.random.default_rng(3)
    total = rng.normal(10, 6, (50, 3))
    assoc = rng.integers(-1, 5, (4, 50, 3)).astype(np.int16)
    dom = box_dominated(total, assoc, [5] * 4, 0.0)
    assert not dom[np.unravel_index(np.argmax(total), total.shape)]
    assert not box_dominated(total, assoc, [5] * 4, np.inf).any()


def test_dominance_margin_is_checked():
    with pytest.raises(InputError, match=r"dominance_margin: got nan, expected a number of nats >= 0"):
        BayesConfig.from_options(dominance_margin=float("nan"))
    with pytest.raises(InputError, match=r"dominance_margin: got -1"):
        BayesConfig.from_options(dominance_margin=-1)


def test_dropping_dominated_hypotheses_keeps_the_objects_of_a_dense_row():
    """On a dense row most cone crossings are ghosts whose boxes better hypotheses hold: dropping them in the
    search scores far fewer hypotheses and finds the same fruit at the same places."""
    from monovisual3d.bench.scale import row_session
    from monovisual3d.methods.bayes.localizer import region_grid
    from monovisual3d.methods.bayes.problem import build_problem

    session, _ = row_session(24, 4, 11)
    n_scored = []
    for margin in (BayesConfig().tuning.dominance_margin, float("inf")):
        config = BayesConfig.from_options(
            use_masks=False, dominance_margin=margin, lazy_last_level=False
        )  # every level in the search
        problem = build_problem(session.camera, config, session.views)
        n_scored.append(search(problem, region_grid(problem.config, session.workspace, session.views[0])).n_scored)
    assert n_scored[0] < 0.6 * n_scored[1]
    pruned = mv.localize(session, use_masks=False)
    full = mv.localize(session, use_masks=False, dominance_margin=float("inf"))
    assert len(pruned.objects) == len(full.objects) >= 23
    order = lambda r: np.lexsort(r.positions.T)  # noqa: E731
    assert_allclose(pruned.positions[order(pruned)], full.positions[order(full)], atol=1e-6)


def test_swap_gate_passes_a_swapped_pair_and_stops_a_right_one():
    """Two fruit 6 cm apart: holding each other's box costs far more than ``match_bonus`` where they stand
    (no refit can mend that), holding their own after a mix-up gains."""
    from monovisual3d.camera import Camera
    from monovisual3d.frames import look_at
    from monovisual3d.geometry.sphere import sphere_bbox
    from monovisual3d.methods.bayes.problem import build_problem
    from monovisual3d.methods.bayes.scoring import predicted_boxes
    from monovisual3d.methods.bayes.state import Found
    from monovisual3d.methods.bayes.swap import swap_worth_fitting
    from monovisual3d.session import Detection, Session, View

    centres, radii = np.array([[0.7, -0.03, 0.5], [0.7, 0.03, 0.5]]), [0.025, 0.025]
    camera = Camera.from_hfov(640, 480, 69.0)
    poses = [look_at(np.array([0.2, dy, 0.5]), np.array([0.7, 0.0, 0.5])) for dy in (0.0, 0.15, -0.15)]
    views = [View(T, tuple(Detection(b) for b in sphere_bbox(camera, T, centres, np.array(radii)))) for T in poses]
    session = Session(camera, tuple(views), None)
    problem = build_problem(session.camera, BayesConfig(use_masks=False), session.views)
    v = 0
    pred = predicted_boxes(problem, v, [Found(c, 20.0, r, None, {}) for c, r in zip(centres, radii)])[0]
    own = [int(np.argmin(np.abs(problem.views[v].boxes - p).sum(axis=1))) for p in pred]
    right = [Found(c, 20.0, r, None, {problem.views[v].index: j}) for c, r, j in zip(centres, radii, own)]
    mixed = [Found(c, 20.0, r, None, {problem.views[v].index: j}) for c, r, j in zip(centres, radii, own[::-1])]
    assert_array_equal(swap_worth_fitting(problem, v, right[:1], right[1:], pred[:1], pred[1:]), [False])
    assert_array_equal(swap_worth_fitting(problem, v, mixed[:1], mixed[1:], pred[:1], pred[1:]), [True])
    # several pairs at once: each answer as alone
    both = swap_worth_fitting(problem, v, [mixed[0], mixed[0]], [right[1], mixed[1]], pred[[0, 0]], pred[[1, 1]])
    assert_array_equal(
        both, [swap_worth_fitting(problem, v, mixed[:1], [o], pred[:1], pred[1:])[0] for o in (right[1], mixed[1])]
    )


def test_predicted_boxes_of_many_objects_are_each_alone():
    """The swap pass and the occlusion flags predict all holders' boxes in one call; each equals that object's box
    predicted alone (a sphere, an upright spheroid and a lying one), with its centre in the optical frame."""
    from monovisual3d.camera import Camera
    from monovisual3d.frames import look_at
    from monovisual3d.geometry.spheroid import predict_spheroid_boxes
    from monovisual3d.methods.bayes.problem import build_problem
    from monovisual3d.methods.bayes.scoring import predicted_boxes
    from monovisual3d.methods.bayes.state import Found
    from monovisual3d.session import Detection, View

    camera = Camera.from_hfov(1280, 720, 69.0)
    T = look_at(np.array([0.1, 0.05, 0.6]), np.array([0.7, 0.0, 0.5]))
    problem = build_problem(camera, BayesConfig(use_masks=False), [View(T, (Detection(np.array([0.0, 0, 10, 10])),))])
    objects = [
        Found(np.array([0.7, -0.05, 0.5]), 1.0, 0.03, None, {}),
        Found(np.array([0.72, 0.0, 0.45]), 1.0, 0.025, None, {}, semi_up=0.06),
        Found(np.array([0.68, 0.06, 0.52]), 1.0, 0.02, None, {}, semi_up=0.05, axis=np.array([0.6, 0.8, 0.0])),
    ]
    R, t = problem.views[0].T_optical_base[:3, :3], problem.views[0].T_optical_base[:3, 3]
    ups = [np.array([0.0, 0, 1]), np.array([0.0, 0, 1]), np.array([0.6, 0.8, 0])]
    alone = [
        predict_spheroid_boxes(camera, (R @ o.position + t)[None], [o.radius], [o.semi_up or o.radius], R @ u)[0][0, 0]
        for o, u in zip(objects, ups)
    ]
    boxes, visible, p_optical = predicted_boxes(problem, 0, objects)
    assert_allclose(boxes, np.array(alone), rtol=0, atol=1e-9)
    assert visible.all()
    assert_allclose(p_optical, [R @ o.position + t for o in objects], rtol=0, atol=1e-12)
