"""The second look at free boxes (methods/bayes/second_look.py)."""

from pathlib import Path

import numpy as np
import pytest

import monovisual3d as mv
from monovisual3d.bench.accuracy import conditions, simulated_session
from monovisual3d.camera import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.ellipsoid import ellipsoid_bbox
from monovisual3d.geometry.orientation import rotation_upright
from monovisual3d.methods.bayes.config import BayesConfig
from monovisual3d.methods.bayes.fits import free_boxes
from monovisual3d.methods.bayes.problem import build_problem
from monovisual3d.methods.bayes.second_look import second_look
from monovisual3d.methods.bayes.state import Found
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import default_camera, paper_scene
from monovisual3d.sim.viewpoints import paper_poses
from monovisual3d.truth import load_objects

DATA = Path(__file__).parent / "data"
SIZE_RANGE_M = (0.02, 0.15)


def _nearest_mm(name, **options):
    """Per true object of the shipped session ``name``, the distance (mm) to the nearest estimate of ``localize``."""
    session = mv.load_session(DATA / f"{name}.session.json")
    truth = load_objects(DATA / f"{name}.truth.json").positions
    est = mv.localize(session, size_range=SIZE_RANGE_M, **options).positions.reshape(-1, 3)
    return 1e3 * np.linalg.norm(est[:, None] - truth[None], axis=2).min(axis=0)


def test_a_lying_object_broadside_in_one_view_only_is_built_from_its_free_boxes():
    # Seed 810 of experiments/tabletop_subsets.py, views (0, 1, 6): four lying boxes and two bottles on a table; one
    # lying object is wide in one view and tall in the other two, so the search has no hypothesis that explains its
    # boxes and leaves them free.
    without = _nearest_mm("one_view_broadside_tabletop", second_look=False)
    assert without[2] > 100  # missed: the pass is what finds it
    found = _nearest_mm("one_view_broadside_tabletop")
    assert found.max() < 10, found
    np.testing.assert_allclose(np.delete(found, 2), np.delete(without, 2), atol=1e-6)  # the others are untouched


def test_a_ghost_of_two_objects_boxes_gives_them_up_to_the_two_objects():
    # Seed 810 of experiments/tabletop_subsets.py, views (1, 4, 5): the search pairs object 3's box in the first view
    # with object 0's in the third into one object seen twice, and leaves the two objects' other boxes free; built from
    # those and the ghost's boxes, the two objects are worth far more than the ghost. The regroup pass (before the
    # second look) undoes it too: either one alone finds both objects.
    without = _nearest_mm("ghost_of_two_tabletop", second_look=False, regroup=False)
    assert without[0] > 50 and without[3] > 50
    for options in ({}, {"regroup": False}, {"second_look": False}):
        found = _nearest_mm("ghost_of_two_tabletop", **options)
        assert found.max() < 10, (options, found)


def test_a_container_wholly_behind_another_in_one_view_is_found_from_its_other_two():
    # Seed 1100 of experiments/container_pairs.py at 0 degrees, views 1, 4 and 7, with boxes of the visible parts and
    # none for an object wholly behind another (--visible --unboxed-hidden --tray --pose-error=1,0.15): in the third
    # view the first container stands behind the second and has no box. The search took its boxes of the other two
    # views for nothing and gave the second container a thin ellipsoid 21 mm off; a new object of those two boxes,
    # hidden in the third view, finds both.
    without = _nearest_mm("in_line_hidden_once", second_look=False)
    assert without[0] > 30 and without[1] > 15
    found = _nearest_mm("in_line_hidden_once")
    assert found[:2].max() < 5, found
    np.testing.assert_allclose(found[2], without[2], atol=1e-6)  # the tray is untouched


def test_a_ghost_of_a_false_positive_and_an_objects_box_is_not_made():
    # greenhouse-clutter seed 13 of `monovisual3d bench accuracy` (a truss, 5 % box noise, false-positive boxes): a
    # fruit's box in one view and a false positive in another make an object 117 mm off that the fruit, refitted on its
    # other two views, would hide behind. Worth 9 nats with the fruit's 10.3 against the fruit's 14.1 alone: it does not
    # pay for one more object (``accept``), and no object is added.
    cond = next(c for c in conditions() if c.name == "greenhouse-clutter")
    scene = cond.scene(13)
    session, _ = simulated_session(scene, cond.noise, 13, masks=False)
    est = mv.localize(session, **cond.method_options("bayes")).positions
    off = 1e3 * np.linalg.norm(est[:, None] - scene.centres[None], axis=2).min(axis=1)
    assert len(est) <= len(scene.centres) and off.max() < 30, off


def _problem(boxes_per_view):
    camera = default_camera()
    views = tuple(
        mv.View(T, tuple(mv.Detection(np.asarray(b, dtype=float)) for b in boxes))
        for T, boxes in zip(paper_poses(), boxes_per_view)
    )
    return build_problem(camera, BayesConfig(), views)


def test_free_boxes_are_those_no_object_holds():
    problem = _problem([[[10, 10, 50, 50], [60, 60, 90, 90]], [[10, 10, 50, 50]], [[1, 1, 9, 9], [20, 20, 40, 40]]])
    holder = Found(np.zeros(3), 9.0, 0.03, None, {0: 1, 2: 0}, 1)
    free = free_boxes(problem, [holder])
    assert [f.tolist() for f in free] == [[0], [0], [1]]
    assert [f.tolist() for f in free_boxes(problem, [])] == [[0, 1], [0], [0, 1]]


@pytest.mark.parametrize("seed", [0, 1])
def test_stray_boxes_whose_rays_do_not_meet_add_nothing(seed):
    # the paper scene's fruit with a false-positive box in each view at a random place: no object is built of them
    session, _ = simulated_session(paper_scene(), NoiseModel(false_positive_rate=1.0), seed, masks=False)
    assert sum(len(v.detections) for v in session.views) > 3 * len(paper_scene().fruits)  # there are stray boxes
    on = mv.localize(session).positions
    off = mv.localize(session, second_look=False).positions
    assert on.shape == off.shape
    np.testing.assert_allclose(np.sort(on, axis=0), np.sort(off, axis=0), atol=1e-9)


LYING_M = np.array([0.0, 0.0, 0.06])  # a lying 240 x 110 x 120 mm box's centre on a table, base frame
LYING_SEMI_AXES_M = (0.12, 0.055, 0.06)
TABLE_CAM = Camera(640, 480, 528.0, 528.0, 319.5, 239.5)


def _lying_object_views(azimuths_deg):
    """Views 1 m from a lying object, 38 degrees above the table, each with the object's exact box."""
    e = np.radians(38.0)
    poses = [
        look_at(LYING_M + np.array([-np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)]), LYING_M)
        for a in np.radians(azimuths_deg)
    ]
    boxes = ellipsoid_bbox(TABLE_CAM, np.array(poses), LYING_M, LYING_SEMI_AXES_M, rotation_upright(0.3), clip=False)
    return tuple(mv.View(T, (mv.Detection(b),)) for T, b in zip(poses, boxes))


def test_free_boxes_in_every_view_make_one_object_holding_them_all():
    # the combinations with the most boxes are fitted first: all 8, not a subset that leaves boxes free
    views = _lying_object_views(np.linspace(-80.0, 80.0, 8))
    problem = build_problem(TABLE_CAM, BayesConfig(size_range=SIZE_RANGE_M), views)
    out = second_look(problem, [])
    assert len(out) == 1
    assert out[0].associations == {v: 0 for v in range(8)}
    assert np.linalg.norm(out[0].position - LYING_M) < 0.005


def test_an_object_seen_twice_takes_its_free_box_of_a_third_view():
    views = _lying_object_views([-60.0, 0.0, 60.0])
    problem = build_problem(TABLE_CAM, BayesConfig(size_range=SIZE_RANGE_M), views)
    twice = Found(LYING_M + 0.01, 9.0, 0.08, None, {0: 0, 1: 0}, 1)
    out = second_look(problem, [twice])
    assert len(out) == 1
    assert out[0].associations == {0: 0, 1: 0, 2: 0}
    assert np.linalg.norm(out[0].position - LYING_M) < 0.005


def test_views_without_detections_leave_the_result_as_it_was():
    # the session's view indices shift, the problem's views do not: the same objects, their associations shifted
    session = mv.load_session(DATA / "one_view_broadside_tabletop.session.json")
    empty = mv.View(session.views[0].T_base_optical, ())
    shifted = mv.Session(session.camera, (empty, *session.views))
    a = mv.localize(session, size_range=SIZE_RANGE_M)
    b = mv.localize(shifted, size_range=SIZE_RANGE_M)
    np.testing.assert_allclose(b.positions, a.positions, atol=1e-9)
    assert [{v + 1: j for v, j in o.associations.items()} for o in a.objects] == [o.associations for o in b.objects]


@pytest.mark.parametrize("name", ["one_view_broadside_tabletop", "ghost_of_two_tabletop"])
def test_no_box_is_held_twice(name):
    result = mv.localize(mv.load_session(DATA / f"{name}.session.json"), size_range=SIZE_RANGE_M)
    held = [(v, j) for o in result.objects for v, j in o.associations.items()]
    assert len(held) == len(set(held))
