"""Objects seen in two or three views that lie apart in depth from the well-seen ones: dropped (``isolated_margin``)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import monovisual3d as mv
from monovisual3d.errors import InputError
from monovisual3d.geometry.ellipsoid import Ellipsoid
from monovisual3d.methods.bayes import BayesConfig
from monovisual3d.methods.bayes.isolated import depths_per_view, isolated_in_depth
from monovisual3d.methods.bayes.problem import build_problem
from monovisual3d.methods.bayes.state import Found
from monovisual3d.session import Detection, Session, View
from monovisual3d.sim.scenes import default_camera
from monovisual3d.sim.viewpoints import paper_poses

CAM = default_camera()
POSES = np.asarray(paper_poses())
#: Three fruit on a plant about 0.5 m in front of the cameras (base frame, metres), radius 25 mm.
PLANT = np.array([[0.5, -0.05, 0.45], [0.52, 0.06, 0.5], [0.48, 0.0, 0.56]])


def _problem(config: BayesConfig):
    views = [View(T, (Detection(np.array([300.0, 200.0, 340.0, 240.0])),)) for T in POSES]
    return build_problem(CAM, config, views)


def _object(position, n_views: int) -> Found:
    return Found(np.asarray(position, dtype=float), 10.0, 0.025, associations={v: 0 for v in range(n_views)})


def test_depths_per_view_are_the_optical_z_of_each_centre() -> None:
    problem = _problem(BayesConfig())
    objs = [_object(p, 3) for p in PLANT]
    d = depths_per_view(problem, objs)
    assert d.shape == (3, 3)
    for v, vd in enumerate(problem.views):
        expect = (vd.T_optical_base[:3, :3] @ PLANT.T).T[:, 2] + vd.T_optical_base[2, 3]
        np.testing.assert_allclose(d[:, v], expect, atol=1e-12)


def test_a_two_view_object_far_behind_the_plant_is_flagged_one_near_it_is_not() -> None:
    problem = _problem(BayesConfig())
    ray = PLANT.mean(axis=0) - POSES[0][:3, 3]
    behind = PLANT.mean(axis=0) + 0.35 * ray / np.linalg.norm(ray)
    objs = [_object(p, 3) for p in PLANT] + [_object(behind, 2), _object(PLANT[0] + [0.0, 0.0, 0.06], 2)]
    assert isolated_in_depth(problem, objs).tolist() == [False, False, False, True, False]
    # everything is kept with fewer than 3 well-seen objects
    assert not isolated_in_depth(problem, objs[:2] + [_object(behind, 2)]).any()
    assert not isolated_in_depth(_problem(BayesConfig(isolated_margin=float("inf"))), objs).any()


def test_a_three_view_object_is_flagged_only_farther_out_than_the_others_span() -> None:
    """Seen in three views, an object must lie outside the others' depths by more than ``isolated_margin`` and more
    than their depth range (``SPREAD_FACTOR`` times) in every view; seen in four, it is kept."""
    problem = _problem(BayesConfig())
    ray = PLANT.mean(axis=0) - POSES[0][:3, 3]
    ray /= np.linalg.norm(ray)
    plant = [_object(p, 3) for p in PLANT]
    spread = np.ptp(depths_per_view(problem, plant), axis=0).max()
    assert 0.02 < spread < 0.1  # the plant is shallower than the margin
    far = PLANT.mean(axis=0) - 0.3 * ray  # 0.3 m in front of the plant, along the first camera's ray
    near = PLANT.mean(axis=0) - 0.13 * ray  # just beyond the margin in the first view, not in every view
    assert isolated_in_depth(problem, plant + [_object(far, 3)]).tolist() == [False] * 3 + [True]
    assert not isolated_in_depth(problem, plant + [_object(near, 3)]).any()
    assert not isolated_in_depth(problem, plant + [_object(far, 4)]).any()
    # a deep scene (a table top): the same offset lies within the others' spread, and the object is kept
    deep = plant + [_object(PLANT[0] + 0.35 * ray, 3)]
    assert not isolated_in_depth(problem, deep + [_object(far, 3)])[-1]
    # the objects of the plant, each judged against the other two plus the far one, are never flagged
    assert not isolated_in_depth(problem, plant + [_object(far, 3)])[:3].any()


def test_a_two_view_object_is_judged_by_its_depth_in_the_views_that_see_it() -> None:
    """Moved off the plant so that its depth changes in views 0 and 1 but not in view 2, an object is flagged when it
    holds boxes in views 0 and 1 (its boxes' rays meet away from the scene), kept when one of its boxes is in view 2."""
    problem = _problem(BayesConfig())
    z = np.array([T[:3, 2] for T in POSES])  # each view's optical axis, base frame
    u = z[0] - (z[0] @ z[2]) * z[2]
    u /= np.linalg.norm(u)  # along it, the depth changes in views 0 and 1, not in view 2
    off = PLANT.mean(axis=0) - 0.4 * u
    plant = [_object(p, 3) for p in PLANT]
    d = depths_per_view(problem, plant + [_object(off, 2)])
    assert np.all(d[3, :2] < d[:3, :2].min(axis=0) - 0.1) and d[:3, 2].min() < d[3, 2] < d[:3, 2].max()
    seen_01 = Found(off, 10.0, 0.025, associations={0: 0, 1: 0})
    seen_12 = Found(off, 10.0, 0.025, associations={1: 0, 2: 0})
    assert isolated_in_depth(problem, plant + [seen_01, seen_12]).tolist() == [False] * 3 + [True, False]


def test_localize_drops_a_fruit_seen_twice_far_behind_the_plant_and_says_so() -> None:
    """Boxes cannot tell a fruit seen in two views from two false boxes whose rays meet; 0.3 m behind a plant whose
    fruit are seen in all three views, it is dropped, and the diagnostics count it."""
    fruit = [Ellipsoid(c, np.full(3, 0.025), np.array([0.0, 0.0, 0.0, 1.0])) for c in PLANT]
    far = Ellipsoid(PLANT.mean(axis=0) + [0.3, 0.12, 0.0], np.full(3, 0.03), np.array([0.0, 0.0, 0.0, 1.0]))
    views = []
    for k, T in enumerate(POSES):
        shown = fruit + ([far] if k < 2 else [])  # the far one in views 0 and 1 only
        views.append(View(T, tuple(Detection(e.bbox(CAM, T)) for e in shown)))
    session = Session(CAM, tuple(views))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kept = mv.localize(session, isolated_margin=float("inf"))
        dropped = mv.localize(session)
    assert len(kept.objects) == 4 and min(np.linalg.norm(kept.positions - far.centre_base, axis=1)) < 0.01
    assert len(dropped.objects) == 3 and dropped.diagnostics["isolated_dropped"] == 1
    assert max(min(np.linalg.norm(dropped.positions - c, axis=1)) for c in PLANT) < 0.005


def test_isolated_margin_is_checked() -> None:
    with pytest.raises(InputError, match="isolated_margin: got -0.1, expected a number of metres >= 0"):
        BayesConfig(isolated_margin=-0.1)
