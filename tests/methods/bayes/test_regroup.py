"""Objects made of several fruit's boxes, extracted again with their neighbours (:mod:`monovisual3d.methods.bayes.regroup`)."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

import monovisual3d as mv
from monovisual3d.methods.bayes.regroup import _grid_worth_again, _Table


def _table(scores, assoc) -> _Table:
    assoc = np.asarray(assoc, dtype=np.int32)
    n = assoc.shape[1]
    return _Table.build(np.asarray(scores, dtype=float), assoc, np.arange(n), np.zeros(n, dtype=np.intp))


def test_table_finds_the_hypotheses_on_boxes_and_counts_the_boxes_they_use() -> None:
    table = _table([20.0, 18.0, 9.0], [[0, 1, -1], [0, 0, 1], [2, -1, 2]])
    every = np.arange(3)
    assert table.using({(0, 0), (1, 0)}, every).tolist() == [2, 1, 0]
    assert table.using({(2, 2)}, every).tolist() == [1, 0, 1]
    assert table.using({(2, 2)}, np.array([2, 0])).tolist() == [1, 1]
    assert table.using(set(), every).tolist() == [0, 0, 0]
    assert table.users({(0, 0), (1, 0)}).tolist() == [0, 1]
    assert table.users({(2, 2), (1, 1)}).tolist() == [0, 2]
    assert table.users({(0, 2)}).tolist() == []  # a box no hypothesis uses
    assert table.users(set()).tolist() == []


def test_grid_worth_again_is_a_greedy_extraction_on_grid_scores() -> None:
    # three views (rows); h0 holds box 0 of every view; h1 and h2 each share one box with h0 but none with each
    # other; h3 shares nothing
    table = _table([20.0, 15.0, 14.0, 9.0], [[0, 0, 1, 2], [0, 1, 0, 2], [0, 1, -1, 2]])
    accept = 8.0
    assert_allclose(_grid_worth_again(table, np.arange(4), accept), (20.0 - accept) + (9.0 - accept), rtol=1e-12)
    # without h0, h1 and h2 are both taken: together worth more than h0 alone
    expected = (15.0 - accept) + (14.0 - accept) + (9.0 - accept)
    assert_allclose(_grid_worth_again(table, np.array([1, 2, 3]), accept), expected, rtol=1e-12)
    # hypotheses below accept add nothing
    assert _grid_worth_again(table, np.array([3]), 10.0) == 0.0


def test_three_fruits_boxes_taken_as_one_object_are_given_back() -> None:
    """Greenhouse-clutter seed 7552: the boxes of fruit 3, 0 and 1 in views 0, 1 and 2 meet 0.14 m in front of the
    plant, where one sphere explains them as well as a fruit (22.9 nats) and the extraction takes it first; fruit 3
    and 0 are then paired crosswise (138 and 152 mm off). Regrouped, every fruit holds its own boxes."""
    from monovisual3d.bench.accuracy import conditions, simulated_session

    cond = next(c for c in conditions() if c.name == "greenhouse-clutter")
    scene = cond.scene(7552)
    session, svs = simulated_session(scene, cond.noise, 7552, masks=False)
    res = mv.localize(session, **cond.method_options("bayes"))
    for f in range(len(scene.centres)):
        d = np.linalg.norm(res.positions - scene.centres[f], axis=1)
        assert d.min() < scene.radii[f]
        held = res.objects[int(np.argmin(d))].associations
        assert all(svs[v].source[j] == f for v, j in held.items())
    off = mv.localize(session, **{**cond.method_options("bayes"), "regroup": False})
    worst = max(np.linalg.norm(off.positions - c, axis=1).min() for c in scene.centres)
    assert worst > 0.1


def _three_fruit_problem():
    from monovisual3d.camera import Camera
    from monovisual3d.frames import look_at
    from monovisual3d.geometry.sphere import sphere_bbox
    from monovisual3d.methods.bayes import BayesConfig
    from monovisual3d.methods.bayes.localizer import region_grid
    from monovisual3d.methods.bayes.problem import build_problem
    from monovisual3d.methods.bayes.search import search
    from monovisual3d.session import Detection, View, Workspace

    cam, target = Camera.from_hfov(640, 480, 69.0), np.array([0.7, 0.0, 0.5])
    centres = target + np.array([[0.0, -0.08, 0.0], [0.02, 0.0, 0.06], [-0.02, 0.08, -0.04]])
    steps = ([-0.5, 0.0, 0.0], [-0.45, 0.15, -0.15], [-0.45, -0.15, 0.15])
    views = [
        View(T, tuple(Detection(b) for b in sphere_bbox(cam, T, centres, np.full(3, 0.03))))
        for T in (look_at(target + s, target) for s in steps)
    ]
    workspace = Workspace(np.array([0.45, -0.3, 0.2]), np.array([1.0, 0.3, 0.8]))
    problem = build_problem(cam, BayesConfig(use_masks=False), views)
    return problem, search(problem, region_grid(problem.config, workspace, views[0])), centres


def test_the_pass_gives_each_fruit_its_own_boxes_back_from_a_crossing_that_took_one_of_each() -> None:
    """Given a bad state (one object holding box 0 of view 0, box 1 of view 1 and box 2 of view 2, each a different
    fruit's, and each fruit its two other boxes), the pass ends with every fruit holding its three boxes."""
    from monovisual3d.methods.bayes.regroup import regroup_pass
    from monovisual3d.methods.bayes.scoring import fit_fixed, held_boxes

    problem, hyp, centres = _three_fruit_problem()
    crossing = fit_fixed(problem, centres.mean(axis=0), 0.03, [0, 1, 2])
    pairs = [fit_fixed(problem, c, 0.03, [-1 if v == f else f for v in range(3)]) for f, c in enumerate(centres)]
    objects = [o for o in [crossing, *pairs] if o is not None]
    assert len(objects) == 4
    every_box = {(v, j) for v in range(3) for j in range(3)}
    out = regroup_pass(problem, objects, hyp)
    assert len(out) == 3 and held_boxes(problem, out) == every_box
    for f, c in enumerate(centres):
        o = min(out, key=lambda o: np.linalg.norm(o.position - c))
        assert o.associations == {0: f, 1: f, 2: f}
        assert np.linalg.norm(o.position - c) < 1e-3


def test_the_pass_leaves_right_objects_as_they_are() -> None:
    from monovisual3d.methods.bayes.regroup import regroup_pass
    from monovisual3d.methods.bayes.scoring import fit_fixed

    problem, hyp, centres = _three_fruit_problem()
    objects = [fit_fixed(problem, c, 0.03, [f, f, f]) for f, c in enumerate(centres)]
    out = regroup_pass(problem, objects, hyp)
    assert [o is p for o, p in zip(out, objects)] == [True] * 3 and len(out) == 3
