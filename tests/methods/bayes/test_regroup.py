"""Objects made of several fruit's boxes, extracted again with their neighbours (:mod:`monovisual3d.methods.bayes.regroup`)."""

from __future__ import annotations

import numpy as np

import monovisual3d as mv
from monovisual3d.methods.bayes.regroup import _grid_worth_again, _Table


def _table(scores, assoc) -> _Table:
    assoc = np.asarray(assoc, dtype=np.int32)
    n = assoc.shape[1]
    return _Table.build(np.asarray(scores, dtype=float), assoc, np.arange(n), np.zeros(n, dtype=np.intp), [3] * len(assoc))


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
    assert _grid_worth_again(table, np.arange(4), accept) == (20.0 - accept) + (9.0 - accept)
    # without h0, h1 and h2 are both taken: together worth more than h0 alone
    assert _grid_worth_again(table, np.array([1, 2, 3]), accept) == (15.0 - accept) + (14.0 - accept) + (9.0 - accept)
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
