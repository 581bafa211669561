"""The shape models' pair moves (methods/bayes/shape_swap.py): two box containers seen side-on with boxes of their
visible parts."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import monovisual3d as mv
from monovisual3d.camera import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.ellipsoid import Ellipsoid
from monovisual3d.geometry.orientation import rotation_upright
from monovisual3d.geometry.solids import cuboid_bbox
from monovisual3d.methods.bayes import BayesConfig
from monovisual3d.methods.bayes.problem import build_problem
from monovisual3d.methods.bayes.shape_swap import boxes_meet, is_tall
from monovisual3d.methods.bayes.shapes import SPHERE_PARAMETERS, shape_value
from monovisual3d.result import DetectedObject
from monovisual3d.session import Detection, Session, View, Workspace
from monovisual3d.sim.noise import perturb_boxes, visible_part_boxes

CAM = Camera.from_hfov(1280, 720, 69.0)
TARGET = np.array([0.6, 0.0, 0.3])
CENTRES = TARGET + np.array([[0.0, -0.0285, 0.0], [0.0, 0.0285, 0.0]])
HALF_SIDES_M = np.array([0.025, 0.025, 0.06])


def _problem(poses: np.ndarray, boxes: np.ndarray):
    views = tuple(View(T, tuple(Detection(b) for b in bs)) for T, bs in zip(poses, boxes))
    return build_problem(CAM, BayesConfig(), views)


def test_boxes_meet_side_by_side_only():
    problem = _problem(np.eye(4)[None], np.array([[[100.0, 100, 160, 300]]]))
    left = np.array([100.0, 100, 160, 300])
    assert boxes_meet(problem, left, np.array([160.0, 110, 200, 290]))  # abutting: one hides part of the other
    assert boxes_meet(problem, left, np.array([140.0, 90, 220, 310]))  # overlapping
    assert not boxes_meet(problem, left, np.array([180.0, 100, 220, 300]))  # a gap of 20 px, 4 edge sigmas
    assert not boxes_meet(problem, left, np.array([160.0, 250, 220, 400]))  # corners only: 50 of 150 px of height


def test_a_hidden_edge_costs_nothing_within_the_nearer_box_only():
    """A sphere whose box's left edge a nearer box hides: predicted anywhere inside the nearer box it costs nothing;
    predicted beyond the nearer box's far side, it would show there, and is scored from that side."""
    T_base_optical = look_at(np.array([0.0, 0.0, 0.3]), np.array([1.0, 0.0, 0.3]))
    centre = np.array([0.6, 0.0, 0.3])
    sphere = Ellipsoid.sphere(centre, 0.03)
    whole = sphere.bbox(CAM, T_base_optical[None])[0]
    seen = whole.copy()
    seen[0] += 8.0  # the left 8 px (1.4 edge sigmas) hidden
    problem = _problem(T_base_optical[None], seen[None, None])
    obj = DetectedObject(centre, 0.0, 0.03, None, {0: 0}, 1, {})
    answer = (obj, sphere, SPHERE_PARAMETERS)
    free = np.full((1, 4), np.nan)
    seen_edges = shape_value(problem, obj, answer, 4)
    within = shape_value(problem, obj, answer, 4, np.where(np.arange(4) == 0, whole[0] - 10.0, free))
    beyond = shape_value(problem, obj, answer, 4, np.where(np.arange(4) == 0, whole[0] + 4.0, free))
    assert within > beyond > seen_edges
    assert within == pytest.approx(shape_value(problem, obj, answer, 4, np.where(np.arange(4) == 0, whole[0], free)))


def test_only_upright_elongated_objects_are_tall():
    def obj(shape: str, semi_axes: list[float]) -> DetectedObject:
        q = np.array([0.0, 0.0, 0.0, 1.0])
        return DetectedObject(TARGET, 0.0, 0.03, None, {}, 1, {}, shape=shape, semi_axes=np.array(semi_axes), quaternion_xyzw=q)

    assert is_tall(obj("spheroid", [0.025, 0.025, 0.06]))
    assert not is_tall(obj("sphere", [0.03, 0.03, 0.03]))
    assert not is_tall(obj("ellipsoid", [0.06, 0.025, 0.025]))  # lying


@pytest.mark.parametrize("azimuths_deg", [(-116.0, 116.0, 141.0), (-167.0, 116.0, 141.0)])
def test_two_box_containers_seen_side_on_with_visible_part_boxes_keep_their_centres(azimuths_deg):
    """Two upright 50 x 50 x 120 mm boxes 57 mm apart, seen from their height, three views, boxes of the visible parts,
    0.5 % box noise. The spheroids of the search pair the farther container's slivers of every view as one thin object
    (or a large sphere behind the nearer one), 23-62 mm off in every seed here; the shape models, with the edges one
    container hides of the other left out, prefer the truth by 6-12 nats (this test fails without the pass)."""
    for seed in range(3):
        rng = np.random.default_rng(seed)
        poses = []
        for az in np.radians(azimuths_deg):
            p = TARGET + rng.uniform(0.5, 0.7) * np.array([np.cos(az), np.sin(az), 0.0])
            poses.append(look_at(p, TARGET + rng.uniform(-0.01, 0.01, 3)))
        poses = np.array(poses)
        yaws = rng.uniform(0.0, np.pi / 2, 2)
        whole = np.stack([cuboid_bbox(CAM, poses, c, HALF_SIDES_M, rotation_upright(y)) for c, y in zip(CENTRES, yaws)], axis=1)
        T_optical_base = np.linalg.inv(poses)
        depths = np.einsum("kj,nj->kn", T_optical_base[:, 2, :3], CENTRES) + T_optical_base[:, 2, 3:4]
        boxes = visible_part_boxes(whole, depths)
        boxes = perturb_boxes(boxes.reshape(-1, 4), 0.005, rng).reshape(boxes.shape)
        views = tuple(View(T, tuple(Detection(b) for b in bs)) for T, bs in zip(poses, boxes))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            objects = mv.localize(Session(CAM, views, Workspace(TARGET - 0.2, TARGET + 0.2))).objects
        assert len(objects) == 2, seed
        d = np.linalg.norm(np.array([o.position for o in objects])[:, None] - CENTRES[None], axis=2)
        assert max(d.min(axis=0)) < 8e-3, (seed, d.min(axis=0))
