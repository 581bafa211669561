"""The bounding-box camera: ray-cast boxes against analytic sphere boxes, occlusion, the slow reference."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d.camera import Camera
from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.sim.raycast import (
    BACKGROUND,
    OCCLUDER,
    boxes_from_labels,
    label_image,
    label_image_reference,
    render,
)
from monovisual3d.sim.scene import Leaf, Scene, Sphere, Stem

CAM = Camera.from_hfov(640, 480, 69.0)
CAM_DISTORTED = Camera(640, 480, 465.0, 465.0, 320.0, 240.0, "plumb_bob", (-0.1, 0.02, 0.001, -0.001))
T = look_at([0.1, 0.0, 0.45], [0.6, 0.0, 0.45])  # looks along base +x; image right = base -y, image down = base -z


def one_sphere(centre, radius):
    return Scene((Sphere(np.asarray(centre, dtype=float), radius),))


def random_spheres_in_view(rng, n):
    """Spheres whose silhouettes lie entirely inside the image."""
    out = []
    while len(out) < n:
        s = one_sphere(
            [0.6 + rng.uniform(-0.1, 0.1), rng.uniform(-0.25, 0.25), 0.45 + rng.uniform(-0.18, 0.18)], rng.uniform(0.02, 0.05)
        )
        box = sphere_bbox(CAM_DISTORTED, T, s.centres, s.radii, clip=False)[0]
        if box[0] > 2 and box[1] > 2 and box[2] < 638 and box[3] < 478:
            out.append(s)
    return out


@pytest.mark.parametrize("camera", [CAM, CAM_DISTORTED], ids=["pinhole", "plumb_bob"])
def test_unoccluded_sphere_box_matches_exact_silhouette_within_a_pixel(camera):
    rng = np.random.default_rng(0)
    for scene in random_spheres_in_view(rng, 5):
        exact = sphere_bbox(camera, T, scene.centres, scene.radii)
        r = render(scene, camera, T)
        assert r.boxes_xyxy.shape == (1, 4)
        assert_allclose(r.boxes_xyxy, exact, atol=1.0)
        assert r.labels.shape == (480, 640) and r.labels.dtype == np.int32


def test_supersampling_gives_sub_pixel_boxes():
    rng = np.random.default_rng(1)
    cam = CAM.scaled(320, 240)
    for scene in random_spheres_in_view(rng, 3):
        exact = sphere_bbox(cam, T, scene.centres, scene.radii)
        r = render(scene, cam, T, supersample=4)
        assert r.labels.shape == (240 * 4, 320 * 4)
        assert_allclose(r.boxes_xyxy, exact, atol=0.3)
        assert_allclose(r.boxes_xyxy * 4, np.round(r.boxes_xyxy * 4))  # edges on the 1/4 px lattice


def test_visible_area_is_the_silhouette_area():
    # sphere on the optical axis: its silhouette is a circle of radius f * tan(asin(r / d)) pixels
    scene = one_sphere([0.6, 0.0, 0.45], 0.05)
    r = render(scene, CAM, T, supersample=2)
    radius_px = CAM.fx * np.tan(np.arcsin(0.05 / 0.5))
    assert_allclose(r.visible_px[0], np.pi * radius_px**2, rtol=0.01)


def test_box_edges_follow_the_pixel_centre_rule():
    # one ray per pixel centre: column i is in the box exactly when the silhouette covers u = i + 0.5
    scene = one_sphere([0.6, 0.0, 0.45], 0.05)
    r = render(scene, CAM, T)
    exact = sphere_bbox(CAM, T, scene.centres, scene.radii)[0]
    assert r.boxes_xyxy[0, 0] == np.ceil(exact[0] - 0.5)
    assert r.boxes_xyxy[0, 2] == np.floor(exact[2] - 0.5) + 1


def test_sphere_cut_by_the_border_gives_the_clipped_box():
    # centre inside the image near the left border (base +y is image left)
    scene = one_sphere([0.6, 0.32, 0.45], 0.05)
    exact = sphere_bbox(CAM, T, scene.centres, scene.radii)[0]
    unclipped = sphere_bbox(CAM, T, scene.centres, scene.radii, clip=False)[0]
    assert unclipped[0] < 0 < unclipped[2]
    box = render(scene, CAM, T).boxes_xyxy[0]
    assert box[0] == 0.0
    assert_allclose(box, exact, atol=1.0)


def test_sphere_mostly_outside_gives_the_box_of_its_visible_part():
    # centre outside the image on the right: the box touches the border and lies within the clipped full box
    scene = one_sphere([0.6, -0.38, 0.5], 0.05)
    unclipped = sphere_bbox(CAM, T, scene.centres, scene.radii, clip=False)[0]
    assert unclipped[0] < 640 < unclipped[2] and (unclipped[0] + unclipped[2]) / 2 > 640
    box = render(scene, CAM, T).boxes_xyxy[0]
    clipped = sphere_bbox(CAM, T, scene.centres, scene.radii)[0]
    assert box[2] == 640.0
    assert box[0] >= clipped[0] - 1 and box[1] >= clipped[1] - 1 and box[3] <= clipped[3] + 1
    assert box[3] - box[1] < clipped[3] - clipped[1] - 2  # the widest rows are outside: shorter than the clipped box


def test_sphere_outside_the_view_has_no_box():
    scene = Scene((Sphere(np.array([0.6, 1.5, 0.45]), 0.05), Sphere(np.array([-0.5, 0.0, 0.45]), 0.05)))
    r = render(scene, CAM, T)
    assert np.all(np.isnan(r.boxes_xyxy))
    assert not r.visible.any()
    assert np.all(r.labels == BACKGROUND)


def leaf_facing_camera(centre, half_size):
    """A leaf in a plane x = const, axis_u along base -y (image right), axis_v along base -z (image down)."""
    return Leaf(np.asarray(centre, dtype=float), np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, -1.0]), half_size)


def test_leaf_hiding_the_right_half_shrinks_the_box():
    sphere = Sphere(np.array([0.6, 0.0, 0.45]), 0.05)
    free = render(Scene((sphere,)), CAM, T)
    # leaf at x = 0.5 covering base y < 0 (the image's right half), well beyond the sphere vertically
    leaf = leaf_facing_camera([0.5, -0.1, 0.45], (0.1, 0.2))
    r = render(Scene((sphere,), (leaf,)), CAM, T)
    assert_array_equal(r.boxes_xyxy[0, [0, 1, 3]], free.boxes_xyxy[0, [0, 1, 3]])
    assert r.boxes_xyxy[0, 2] == 320.0  # the leaf edge y = 0 projects onto the image centre column
    assert_allclose(r.visible_px[0], free.visible_px[0] / 2, rtol=0.02)
    assert np.any(r.labels == OCCLUDER)


def test_leaf_in_front_hides_the_fruit_completely():
    sphere = Sphere(np.array([0.6, 0.0, 0.45]), 0.05)
    leaf = leaf_facing_camera([0.45, 0.0, 0.45], (0.1, 0.1))
    r = render(Scene((sphere,), (leaf,)), CAM, T)
    assert np.all(np.isnan(r.boxes_xyxy)) and r.visible_px[0] == 0
    assert not np.any(r.labels == 0)


def test_leaf_behind_the_fruit_changes_nothing():
    sphere = Sphere(np.array([0.6, 0.0, 0.45]), 0.05)
    leaf = leaf_facing_camera([0.7, 0.0, 0.45], (0.2, 0.2))
    free = render(Scene((sphere,)), CAM, T)
    r = render(Scene((sphere,), (leaf,)), CAM, T)
    assert_array_equal(r.boxes_xyxy, free.boxes_xyxy)
    assert_array_equal(r.visible_px, free.visible_px)


def test_leaf_seen_edge_on_hides_nothing():
    sphere = Sphere(np.array([0.6, 0.0, 0.45]), 0.05)
    # the leaf plane contains the optical axis (normal along base y)
    leaf = Leaf(np.array([0.5, 0.0, 0.45]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), (0.05, 0.1))
    r = render(Scene((sphere,), (leaf,)), CAM, T)
    assert not np.any(r.labels == OCCLUDER)


def test_thin_stem_in_front_keeps_the_box_but_hides_pixels():
    sphere = Sphere(np.array([0.6, 0.0, 0.45]), 0.05)
    stem = Stem(np.array([0.5, 0.0, 0.2]), np.array([0.5, 0.0, 0.7]), 0.005)
    free = render(Scene((sphere,)), CAM, T)
    r = render(Scene((sphere,), (stem,)), CAM, T)
    # the fruit shows on both sides of the stem: same columns; the stem may hide the few pixels of the top and bottom rows
    assert_array_equal(r.boxes_xyxy[0, [0, 2]], free.boxes_xyxy[0, [0, 2]])
    assert_allclose(r.boxes_xyxy, free.boxes_xyxy, atol=1.0)
    assert r.labels[240, 320] == OCCLUDER
    # the stem is 2 * 0.005 / 0.4 * f = 11.6 px wide in front of the fruit
    hidden = free.visible_px[0] - r.visible_px[0]
    stem_px = 2 * 0.005 / 0.4 * CAM.fx
    assert (
        0.8 * stem_px * (free.boxes_xyxy[0, 3] - free.boxes_xyxy[0, 1])
        < hidden
        < 1.2 * stem_px * (free.boxes_xyxy[0, 3] - free.boxes_xyxy[0, 1])
    )


def test_stem_seen_along_its_axis_shows_its_end_cap():
    stem = Stem(np.array([0.4, 0.0, 0.45]), np.array([0.8, 0.0, 0.45]), 0.02)  # along the optical axis
    labels = label_image(Scene((), (stem,)), CAM, T)
    disc_px = np.pi * (CAM.fx * 0.02 / 0.3) ** 2
    assert labels[240, 320] == OCCLUDER
    assert_allclose(np.sum(labels == OCCLUDER), disc_px, rtol=0.05)


def test_finite_stem_ends():
    stem = Stem(np.array([0.5, 0.0, 0.45]), np.array([0.5, 0.0, 0.6]), 0.01)  # from the centre row upwards only
    labels = label_image(Scene((), (stem,)), CAM, T)
    rows = np.flatnonzero(np.any(labels == OCCLUDER, axis=1))
    top_px = 240 - CAM.fy * 0.15 / 0.39  # the near edge of the top cap (x = 0.49) is the highest point seen
    assert_allclose([rows.min(), rows.max() + 1], [top_px, 240], atol=1)


def test_nearer_fruit_hides_the_one_behind():
    near = Sphere(np.array([0.5, 0.0, 0.45]), 0.05)
    far = Sphere(np.array([0.7, 0.0, 0.45]), 0.05)  # same direction, farther: fully behind the near one
    side = Sphere(np.array([0.7, 0.0, 0.45 + 0.08]), 0.05)  # partly behind
    r = render(Scene((far, near, side)), CAM, T)
    assert np.all(np.isnan(r.boxes_xyxy[0]))
    alone = render(Scene((side,)), CAM, T)
    assert r.visible_px[2] < alone.visible_px[0]
    assert r.boxes_xyxy[2, 3] < alone.boxes_xyxy[0, 3]  # its bottom (toward the near fruit) is cut


def test_min_pixels_hides_tiny_fruit():
    scene = one_sphere([0.6, 0.0, 0.45], 0.05)
    r = render(scene, CAM, T, min_pixels=1e9)
    assert np.all(np.isnan(r.boxes_xyxy)) and r.visible_px[0] > 0


@pytest.mark.parametrize("camera, supersample", [(CAM.scaled(48, 36), 1), (CAM_DISTORTED.scaled(32, 24), 2)])
def test_vectorised_kernel_matches_the_per_ray_reference(camera, supersample):
    rng = np.random.default_rng(3)
    fruits = tuple(
        Sphere(
            np.array([0.6 + rng.uniform(-0.1, 0.1), rng.uniform(-0.2, 0.2), 0.45 + rng.uniform(-0.15, 0.15)]),
            rng.uniform(0.02, 0.06),
        )
        for _ in range(5)
    )
    occ = []
    for _ in range(4):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        v = np.cross(u, rng.normal(size=3))
        v /= np.linalg.norm(v)
        occ.append(Leaf(np.array([0.5, rng.uniform(-0.2, 0.2), 0.45 + rng.uniform(-0.15, 0.15)]), u, v, (0.05, 0.03)))
    occ.append(Stem(np.array([0.55, 0.05, 0.2]), np.array([0.5, -0.05, 0.7]), 0.01))
    occ.append(Stem(np.array([0.45, -0.1, 0.35]), np.array([0.6, -0.15, 0.4]), 0.02))
    scene = Scene(fruits, tuple(occ))
    fast = label_image(scene, camera, T, supersample=supersample, tile=7)
    slow = label_image_reference(scene, camera, T, supersample=supersample)
    assert set(np.unique(fast)) >= {BACKGROUND, OCCLUDER, 0}
    assert_array_equal(fast, slow)


def test_tile_size_does_not_change_the_result():
    scene = Scene((Sphere(np.array([0.6, 0.0, 0.45]), 0.05),), (leaf_facing_camera([0.5, -0.1, 0.45], (0.05, 0.05)),))
    cam = CAM.scaled(160, 120)
    assert_array_equal(label_image(scene, cam, T, tile=5), label_image(scene, cam, T, tile=1000))


def test_boxes_from_labels_edge_convention():
    labels = np.full((6, 8), BACKGROUND, dtype=np.int32)
    labels[2, 3] = 0  # a single pixel -> (3, 2, 4, 3)
    labels[1:4, 5:8] = 2
    labels[0, 0] = OCCLUDER
    boxes, counts = boxes_from_labels(labels, 3)
    assert_array_equal(boxes[0], [3, 2, 4, 3])
    assert np.all(np.isnan(boxes[1]))
    assert_array_equal(boxes[2], [5, 1, 8, 4])
    assert_array_equal(counts, [1, 0, 9])
    boxes2, _ = boxes_from_labels(labels, 3, supersample=2)
    assert_array_equal(boxes2[2], [2.5, 0.5, 4.0, 2.0])


def test_bad_inputs_are_rejected():
    scene = one_sphere([0.6, 0.0, 0.45], 0.05)
    with pytest.raises(InputError, match=r"--supersample \(supersample\): got 0"):
        render(scene, CAM, T, supersample=0)
    with pytest.raises(InputError, match="T_base_optical"):
        render(scene, CAM, np.eye(3))
    skew = Leaf(np.array([0.5, 0.0, 0.45]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 1.0, 1.0]), (0.05, 0.05))
    with pytest.raises(InputError, match="not orthogonal"):
        render(Scene((), (skew,)), CAM, T)
    with pytest.raises(InputError, match="labels: contains fruit index 4"):
        boxes_from_labels(np.full((2, 2), 4), 2)
    with pytest.raises(InputError, match="tile: got 0"):
        label_image(scene, CAM, T, tile=0)


def test_empty_scene_is_background():
    labels = label_image(Scene(()), CAM.scaled(32, 24), T)
    assert np.all(labels == BACKGROUND)
