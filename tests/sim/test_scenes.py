"""Built-in scenes: paper, greenhouse, random; JSON round trip."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.errors import InputError
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.sim.raycast import render
from monovisual3d.sim.scene import Leaf, Scene, Stem
from monovisual3d.sim.scenes import (
    default_camera,
    greenhouse_scene,
    paper_scene,
    random_scene,
    scene_by_name,
    scene_target,
)
from monovisual3d.sim.viewpoints import DEFAULT_TARGET, paper_poses

CAM = default_camera()
HALF_CAM = CAM.scaled(320, 240)


def pairwise_gaps(scene):
    c, r = scene.centres, scene.radii
    d = np.linalg.norm(c[:, None] - c[None], axis=-1) - r[:, None] - r[None]
    return d[~np.eye(len(r), dtype=bool)]


def test_paper_scene_has_six_spheres_of_5_and_10_cm_about_half_a_metre_away():
    s = paper_scene()
    assert len(s.fruits) == 6 and not s.occluders
    assert sorted(np.round(2 * s.radii, 3).tolist()) == [0.05] * 3 + [0.1] * 3
    assert np.all(pairwise_gaps(s) > 0)
    cam_position = paper_poses()[0, :3, 3]
    depth = s.centres[:, 0] - cam_position[0]
    assert np.all((depth > 0.4) & (depth < 0.6))
    assert_allclose(scene_target(s), DEFAULT_TARGET)


def test_paper_scene_is_fully_visible_from_the_three_paper_poses():
    s = paper_scene()
    for T in paper_poses():
        r = render(s, CAM, T)
        exact = sphere_bbox(CAM, T, s.centres, s.radii, clip=False)
        assert np.all(exact[:, :2] > 0) and np.all(exact[:, 2] < CAM.width) and np.all(exact[:, 3] < CAM.height)
        assert_allclose(r.boxes_xyxy, exact, atol=1.0)
        for i, f in enumerate(s.fruits):  # no sphere hides any part of another
            assert r.visible_px[i] == render(Scene((f,)), CAM, T).visible_px[0]


def visible_fraction(scene, T, camera=HALF_CAM):
    r = render(scene, camera, T)
    alone = np.array([render(Scene((f,)), camera, T).visible_px[0] for f in scene.fruits])
    return r.visible_px / alone


@pytest.mark.parametrize("seed", [0, 1])
def test_greenhouse_scene_is_a_partly_occluded_truss_visible_from_two_views(seed):
    s = greenhouse_scene(seed)
    assert 5 <= len(s.fruits) <= 10
    assert np.all((s.radii >= 0.02) & (s.radii <= 0.04))
    assert np.all(pairwise_gaps(s) > 0)
    assert any(isinstance(o, Leaf) for o in s.occluders) and any(isinstance(o, Stem) for o in s.occluders)
    fractions = np.array([visible_fraction(s, T) for T in paper_poses(scene_target(s))])  # (views, fruit)
    assert np.all(np.sum(fractions >= 0.25, axis=0) >= 2)  # every fruit well visible in >= 2 views
    assert np.any(fractions < 0.9)  # leaves, stems or other fruit do hide parts of some fruit
    # clustered: every fruit within 5 cm (surface to surface) of another one, all within 0.3 m of the target
    d = np.linalg.norm(s.centres[:, None] - s.centres[None], axis=-1) - s.radii[:, None] - s.radii[None]
    d[np.eye(len(s.fruits), dtype=bool)] = np.inf
    assert np.all(d.min(axis=1) < 0.05)
    assert np.all(np.linalg.norm(s.centres - np.array(DEFAULT_TARGET), axis=1) < 0.3)


def test_greenhouse_scene_options_and_seeds():
    a = greenhouse_scene(5, n_fruit=6, n_leaves=2)
    assert len(a.fruits) == 6 and sum(isinstance(o, Leaf) for o in a.occluders) == 2
    assert a.to_dict() == greenhouse_scene(5, n_fruit=6, n_leaves=2).to_dict()
    assert a.to_dict() != greenhouse_scene(6, n_fruit=6, n_leaves=2).to_dict()
    with pytest.raises(InputError, match="n_fruit: got 0"):
        greenhouse_scene(0, n_fruit=0)
    with pytest.raises(InputError, match="min_views: got 4"):
        greenhouse_scene(0, min_views=4)


def test_random_scene():
    s = random_scene(8, rng=3, half_extent=(0.1, 0.2, 0.15), radius_range=(0.02, 0.04), min_gap=0.01)
    assert len(s.fruits) == 8
    assert np.all(pairwise_gaps(s) >= 0.01 - 1e-12)
    assert np.all((s.radii >= 0.02) & (s.radii <= 0.04))
    assert np.all(np.abs(s.centres - np.array(DEFAULT_TARGET)) <= np.array([0.1, 0.2, 0.15]))
    assert s.to_dict() == random_scene(8, rng=3, half_extent=(0.1, 0.2, 0.15), radius_range=(0.02, 0.04), min_gap=0.01).to_dict()
    with pytest.raises(InputError, match="n_fruit: placed only"):
        random_scene(50, rng=0, half_extent=(0.05, 0.05, 0.05), max_tries=2000)
    with pytest.raises(InputError, match="radius_range"):
        random_scene(2, rng=0, radius_range=(0.05, 0.01))


def test_scene_by_name():
    assert scene_by_name("paper").to_dict() == paper_scene().to_dict()
    assert len(scene_by_name("random", rng=0).fruits) == 6
    assert len(scene_by_name("random", rng=0, n_fruit=3).fruits) == 3
    with pytest.raises(InputError, match="scene: got 'orchard'"):
        scene_by_name("orchard")
    with pytest.raises(InputError, match="the paper scene has 6 spheres"):
        scene_by_name("paper", n_fruit=2)


@pytest.mark.parametrize("make", [paper_scene, lambda: greenhouse_scene(2), lambda: random_scene(4, rng=1)])
def test_scene_json_round_trip(tmp_path, make):
    s = make()
    path = tmp_path / "scene.json"
    s.save(path)
    loaded = Scene.load(path)
    assert loaded.to_dict() == s.to_dict()
    assert_allclose(loaded.centres, s.centres)
    assert_allclose(scene_target(loaded), scene_target(s))
    # the rendering is the same too (occluders survive the round trip)
    T = paper_poses(scene_target(s))[0]
    cam = CAM.scaled(160, 120)
    assert np.array_equal(render(loaded, cam, T).labels, render(s, cam, T).labels)


def test_scene_target_falls_back_to_the_centroid():
    s = Scene(random_scene(3, rng=0).fruits)
    assert_allclose(scene_target(s), s.centres.mean(axis=0))
    with pytest.raises(InputError, match="no fruit"):
        scene_target(Scene(()))
