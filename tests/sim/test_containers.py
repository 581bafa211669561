"""The containers-on-a-bench scenes of the experiments: views on an arc, upright solids, pairs with a tray, arm poses."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d.errors import InputError
from monovisual3d.frames import check_transform, invert_transform
from monovisual3d.sim.containers import (
    AIM_JITTER_M,
    DISTANCE_M,
    HALF_HEIGHT_M,
    MIDDLE_JITTER_M,
    SPACING_M,
    TARGET_BASE,
    TRAY_HALF_SIDES_M,
    TRAY_OFFSET_M,
    UprightSolid,
    arc_views,
    arm_camera,
    container_pair,
    detector_boxes,
    reported_poses,
    scene_middle,
    tray_offset_under,
)

#: Boxes of nested solids are compared to this many pixels (they touch where the silhouettes do).
NESTED_TOL_PX = 1e-6


def _contains(outer: np.ndarray, inner: np.ndarray) -> bool:
    """Every box of ``inner`` (..., 4) lies inside the box of ``outer`` at the same index."""
    return bool(
        np.all(outer[..., :2] <= inner[..., :2] + NESTED_TOL_PX) and np.all(outer[..., 2:] >= inner[..., 2:] - NESTED_TOL_PX)
    )


def test_arm_camera_is_69_degrees_wide() -> None:
    cam = arm_camera()
    assert (cam.width, cam.height) == (1280, 720)
    assert np.degrees(2 * np.arctan(cam.width / 2 / cam.fx)) == pytest.approx(69.0)
    assert (arm_camera(640, 480).width, arm_camera(640, 480).height) == (640, 480)


def test_scene_middle_is_near_the_target_and_seeded() -> None:
    m = scene_middle(3)
    assert m.shape == (3,) and np.all(np.abs(m - TARGET_BASE) <= MIDDLE_JITTER_M)
    assert_array_equal(scene_middle(3), m)
    assert not np.array_equal(scene_middle(4), m)


@pytest.mark.parametrize(("n_views", "span_deg"), [(3, 120.0), (8, 180.0)])
def test_arc_views_stand_on_the_minus_x_side_at_the_given_elevation(n_views: int, span_deg: float) -> None:
    centre = np.array(TARGET_BASE)
    T = arc_views(n_views, 25.0, centre, rng=7)
    assert T.shape == (n_views, 4, 4)
    for t in T:
        check_transform(t)
    offset = T[:, :3, 3] - centre
    distance = np.linalg.norm(offset, axis=1)
    assert np.all((distance >= DISTANCE_M[0]) & (distance <= DISTANCE_M[1]))
    assert_allclose(np.degrees(np.arcsin(offset[:, 2] / distance)), 25.0)
    azimuth = np.degrees(np.arctan2(offset[:, 1], -offset[:, 0]))
    assert_allclose(azimuth, np.linspace(-span_deg / 2, span_deg / 2, n_views), atol=1e-9)
    # the optical axis (z) passes within the aim jitter of the centre
    to_centre = centre - T[:, :3, 3]
    along = np.einsum("ki,ki->k", to_centre, T[:, :3, 2])
    miss = np.linalg.norm(to_centre - along[:, None] * T[:, :3, 2], axis=1)
    assert np.all(along > 0) and np.all(miss <= np.sqrt(3) * AIM_JITTER_M)


def test_arc_views_take_one_elevation_per_view_and_are_seeded() -> None:
    elevations = np.array([0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0])
    T = arc_views(8, elevations, TARGET_BASE, rng=1)
    offset = T[:, :3, 3] - TARGET_BASE
    assert_allclose(np.degrees(np.arcsin(offset[:, 2] / np.linalg.norm(offset, axis=1))), elevations, atol=1e-9)
    assert_array_equal(arc_views(8, elevations, TARGET_BASE, rng=1), T)
    assert not np.array_equal(arc_views(8, elevations, TARGET_BASE, rng=2), T)


def test_arc_views_refuse_other_view_counts() -> None:
    with pytest.raises(InputError, match="n_views: got 5, expected one of"):
        arc_views(5, 0.0, TARGET_BASE)


def test_upright_solid_draws_a_yaw_for_cuboids_only() -> None:
    rng = np.random.default_rng(0)
    cuboid = UprightSolid.draw("cuboid", 0.025, 0.06, rng)
    assert cuboid.semi_axes_m == (0.025, 0.025, 0.06) and 0.0 <= cuboid.yaw_rad < np.pi / 2
    state = rng.bit_generator.state
    assert UprightSolid.draw("cylinder", 0.025, 0.06, rng).yaw_rad == 0.0
    assert rng.bit_generator.state == state  # nothing drawn


def test_upright_solid_refuses_bad_input() -> None:
    with pytest.raises(InputError, match="kind: got 'sphere'"):
        UprightSolid("sphere", (0.02, 0.02, 0.02))
    with pytest.raises(InputError, match="semi_axes_m: got"):
        UprightSolid("cuboid", (0.02, 0.0, 0.02))


def test_nested_solids_have_nested_boxes() -> None:
    """A square cuboid holds the cylinder of the same half-width and height, which holds the ellipsoid of those
    semi-axes: so do their boxes, in every view."""
    cam, centre = arm_camera(), np.array(TARGET_BASE)
    T = arc_views(8, 30.0, centre, rng=5)
    cuboid = UprightSolid("cuboid", (0.025, 0.025, 0.06)).boxes(cam, T, centre)
    cylinder = UprightSolid("cylinder", (0.025, 0.025, 0.06)).boxes(cam, T, centre)
    ellipsoid = UprightSolid("ellipsoid", (0.025, 0.025, 0.06)).boxes(cam, T, centre)
    assert cuboid.shape == cylinder.shape == ellipsoid.shape == (8, 4)
    assert _contains(cuboid, cylinder) and _contains(cylinder, ellipsoid)
    assert not np.allclose(cuboid, ellipsoid)  # the solids' boxes are larger: the bias the experiments measure


def test_container_pair_stands_side_by_side_with_its_tray() -> None:
    scene = container_pair(500, "cuboid")
    assert scene.centres_base.shape == (2, 3) and scene.T_base_optical.shape == (8, 4, 4)
    assert_allclose(scene.centres_base[1] - scene.centres_base[0], [0.0, SPACING_M, 0.0], atol=1e-15)
    behind = container_pair(500, "cuboid", tray="behind")
    middle = behind.centres_base[:2].mean(axis=0)
    assert_allclose(behind.centres_base[2] - middle, TRAY_OFFSET_M, atol=1e-15)
    assert behind.solids[2].semi_axes_m == TRAY_HALF_SIDES_M
    under = container_pair(500, "cylinder", tray="under", size_m=(0.03, 0.05, 0.07))
    assert_allclose(under.centres_base[2] - under.centres_base[:2].mean(axis=0), [0.0, 0.0, -0.065], atol=1e-15)
    assert tray_offset_under(HALF_HEIGHT_M) == (0.0, 0.0, -(HALF_HEIGHT_M + TRAY_HALF_SIDES_M[2]))
    assert [s.kind for s in under.solids] == ["cylinder", "cylinder", "cuboid"]


def test_container_pair_is_seeded_and_mixes_elevations_in_a_range() -> None:
    a, b = container_pair(7, elevation_deg=(0.0, 30.0)), container_pair(7, elevation_deg=(0.0, 30.0))
    assert_array_equal(a.centres_base, b.centres_base)
    assert_array_equal(a.T_base_optical, b.T_base_optical)
    offset = a.T_base_optical[:, :3, 3] - a.centres_base.mean(axis=0)
    elevation = np.degrees(np.arcsin(offset[:, 2] / np.linalg.norm(offset, axis=1)))
    assert np.ptp(elevation) > 5.0 and np.all((elevation > -2.0) & (elevation < 32.0))  # the aim point is off the middle
    with pytest.raises(InputError, match="tray: got 'above'"):
        container_pair(0, tray="above")


def test_detector_boxes_whole_visible_and_noisy() -> None:
    cam = arm_camera()
    scene = container_pair(1100, "cuboid", elevation_deg=0.0, tray="behind")
    exact, shown = detector_boxes(scene, cam, 0.0)
    assert exact.shape == (8, 3, 4) and shown.shape == (8, 3) and shown.all()
    assert_array_equal(exact, scene.boxes(cam))
    visible, _ = detector_boxes(scene, cam, 0.0, visible=True)
    assert _contains(exact, visible)  # a visible part's box lies inside the whole silhouette's
    assert not np.allclose(visible, exact)  # at 0 degrees the containers hide each other
    _, shown = detector_boxes(scene, cam, 0.0, visible=True, unboxed_hidden=True)
    assert shown.shape == (8, 3)
    noisy, _ = detector_boxes(scene, cam, 0.02, rng=3)
    assert_array_equal(detector_boxes(scene, cam, 0.02, rng=3)[0], noisy)
    assert 0 < np.abs(noisy - exact).max() < 0.2 * np.max(exact[..., 2:] - exact[..., :2])


def test_depths_are_along_each_optical_axis() -> None:
    scene = container_pair(2)
    depths = scene.depths()
    T_optical_base = np.array([invert_transform(T) for T in scene.T_base_optical])
    p_optical = np.einsum("kij,nj->kni", T_optical_base[:, :3, :3], scene.centres_base) + T_optical_base[:, None, :3, 3]
    assert_allclose(depths, p_optical[..., 2], atol=1e-12)
    assert np.all(depths > DISTANCE_M[0] - 0.05)


def test_reported_poses_keep_a_hand_eye_error_the_same_in_every_view() -> None:
    T = arc_views(8, 10.0, TARGET_BASE, rng=0)
    assert_allclose(reported_poses(T, rng=1), T)
    reported = reported_poses(T, hand_eye_error=(0.001, np.radians(0.3)), rng=1)
    E = np.array([invert_transform(t) @ r for t, r in zip(T, reported)])
    assert_allclose(E, np.broadcast_to(E[0], E.shape), atol=1e-12)  # one error in the camera's own frame
    assert 0 < np.linalg.norm(E[0][:3, 3]) < 0.01
    jittered = reported_poses(T, pose_error=(0.002, 0.0), rng=1)
    step = np.linalg.norm(jittered[:, :3, 3] - T[:, :3, 3], axis=1)
    assert np.all(step > 0) and len(np.unique(step.round(9))) == 8  # drawn anew in each view
    assert_allclose(jittered[:, :3, :3], T[:, :3, :3])
