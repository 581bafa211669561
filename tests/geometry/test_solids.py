"""Boxes of cylinders and cuboids against dense sampling of their rims, edges and surfaces; fits of them."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from monovisual3d.camera import Camera
from monovisual3d.errors import InputError
from monovisual3d.frames import invert_transform, look_at, transform_points
from monovisual3d.geometry.fit import fit_ellipsoid_to_boxes, fit_shape_by_bic
from monovisual3d.geometry.orientation import rotation_upright
from monovisual3d.geometry.solids import circle_bbox_optical, cuboid_bbox, cylinder_bbox, union_boxes

PINHOLE = Camera.from_hfov(1280, 720, 69.0)
DISTORTED = Camera(640, 480, 465.0, 466.0, 321.0, 238.0, "plumb_bob", (-0.25, 0.08, 0.001, -0.0015, 0.0))
DENSE = 20000


def views(rng: np.random.Generator, target: np.ndarray, n: int) -> np.ndarray:
    """n poses (n, 4, 4) 0.5-0.7 m from ``target``, 0-30 degrees above it, aimed within 2 cm of it."""
    out = []
    for az in rng.uniform(-np.pi, np.pi, n):
        e, d = rng.uniform(0.0, np.radians(30.0)), rng.uniform(0.5, 0.7)
        p = target + d * np.array([np.cos(e) * np.cos(az), np.cos(e) * np.sin(az), np.sin(e)])
        out.append(look_at(p, target + rng.uniform(-0.02, 0.02, 3)))
    return np.array(out)


def dense_box(camera: Camera, T_base_optical: np.ndarray, p_base: np.ndarray) -> np.ndarray:
    """The box (4,) of points (M, 3) seen from one pose."""
    uv = camera.project(transform_points(invert_transform(T_base_optical), p_base))
    return np.concatenate([uv.min(axis=0), uv.max(axis=0)])


def cylinder_surface(centre: np.ndarray, r: float, h: float, R: np.ndarray) -> np.ndarray:
    """Dense points (M, 3) of the cylinder's rims and of its side (the silhouette's extremes lie on the rims)."""
    t = np.linspace(0.0, 2 * np.pi, DENSE, endpoint=False)
    rims = [centre + r * (np.cos(t)[:, None] * R[:, 0] + np.sin(t)[:, None] * R[:, 1]) + s * h * R[:, 2] for s in (-1, 1)]
    z = np.linspace(-1.0, 1.0, 50)
    ts = t[::100]
    side = centre + r * (np.cos(ts)[:, None, None] * R[:, 0] + np.sin(ts)[:, None, None] * R[:, 1]) + (z[:, None] * h * R[:, 2])
    return np.concatenate([*rims, side.reshape(-1, 3)])


def cuboid_surface(centre: np.ndarray, half: np.ndarray, R: np.ndarray, n: int = 40) -> np.ndarray:
    """Dense points (M, 3) on the six faces of a cuboid."""
    g = np.linspace(-1.0, 1.0, n)
    a, b = np.meshgrid(g, g)
    faces = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            q = np.zeros((a.size, 3))
            others = [k for k in range(3) if k != axis]
            q[:, axis], q[:, others[0]], q[:, others[1]] = sign, a.ravel(), b.ravel()
            faces.append(q)
    return centre + (np.concatenate(faces) * half) @ R.T


@pytest.mark.parametrize("camera", [PINHOLE, DISTORTED], ids=["pinhole", "distorted"])
def test_circle_box_matches_dense_rim(camera: Camera) -> None:
    rng = np.random.default_rng(11)
    for _ in range(10):
        c = np.array([rng.uniform(-0.1, 0.1), rng.uniform(-0.08, 0.08), rng.uniform(0.4, 0.8)])
        R, r = Rotation.random(random_state=rng).as_matrix(), rng.uniform(0.01, 0.06)
        t = np.linspace(0.0, 2 * np.pi, DENSE, endpoint=False)
        uv = camera.project(c + r * (np.cos(t)[:, None] * R[:, 0] + np.sin(t)[:, None] * R[:, 1]))
        expected = np.concatenate([uv.min(axis=0), uv.max(axis=0)])
        tol = 1e-3 if camera is PINHOLE else 0.05  # closed form vs 360 sampled points under distortion
        assert_allclose(circle_bbox_optical(camera, c, r, R), expected, atol=tol)


@pytest.mark.parametrize("camera", [PINHOLE, DISTORTED], ids=["pinhole", "distorted"])
def test_cylinder_box_matches_dense_surface(camera: Camera) -> None:
    rng = np.random.default_rng(12)
    target = np.array([0.6, 0.0, 0.3])
    for _ in range(6):
        centre = target + rng.uniform(-0.02, 0.02, 3)
        r, h = rng.uniform(0.02, 0.04), rng.uniform(0.03, 0.08)
        R = rotation_upright(rng.uniform(0, np.pi)) if rng.random() < 0.5 else Rotation.random(random_state=rng).as_matrix()
        poses = views(rng, target, 4)
        got = cylinder_bbox(camera, poses, centre, r, h, R)
        expected = np.array([dense_box(camera, T, cylinder_surface(centre, r, h, R)) for T in poses])
        assert_allclose(got, expected, atol=1e-3 if camera is PINHOLE else 0.05)


@pytest.mark.parametrize("camera", [PINHOLE, DISTORTED], ids=["pinhole", "distorted"])
def test_cuboid_box_matches_dense_faces(camera: Camera) -> None:
    rng = np.random.default_rng(13)
    target = np.array([0.6, 0.0, 0.3])
    for _ in range(6):
        centre, half = target + rng.uniform(-0.02, 0.02, 3), rng.uniform(0.015, 0.07, 3)
        R = Rotation.random(random_state=rng).as_matrix()
        poses = views(rng, target, 4)
        got = cuboid_bbox(camera, poses, centre, half, R)
        expected = np.array([dense_box(camera, T, cuboid_surface(centre, half, R, 200)) for T in poses])
        assert_allclose(got, expected, atol=1e-6 if camera is PINHOLE else 0.05)


def test_boxes_broadcast_over_objects_and_views() -> None:
    rng = np.random.default_rng(14)
    poses = views(rng, np.array([0.6, 0.0, 0.3]), 3)
    centres = np.array([0.6, 0.0, 0.3]) + rng.uniform(-0.02, 0.02, (5, 3))
    R = rotation_upright(rng.uniform(0, np.pi, 5))
    batch = cylinder_bbox(PINHOLE, poses, centres[:, None], np.full((5, 1), 0.025), np.full((5, 1), 0.06), R[:, None])
    assert batch.shape == (5, 3, 4)
    for i in range(5):
        assert_allclose(batch[i], cylinder_bbox(PINHOLE, poses, centres[i], 0.025, 0.06, R[i]), atol=1e-9)
    cub = cuboid_bbox(PINHOLE, poses, centres[:, None], np.full((5, 1, 3), 0.03), R[:, None])
    assert cub.shape == (5, 3, 4)
    assert_allclose(cub[2], cuboid_bbox(PINHOLE, poses, centres[2], [0.03] * 3, R[2]), atol=1e-9)


def test_behind_the_camera_is_nan_and_union() -> None:
    T = look_at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    assert np.all(np.isnan(cylinder_bbox(PINHOLE, T, [-1.0, 0.0, 0.0], 0.05, 0.1, np.eye(3))))
    assert np.all(np.isnan(cuboid_bbox(PINHOLE, T, [0.02, 0.0, 0.0], [0.05, 0.05, 0.05], np.eye(3))))  # around the camera
    assert_allclose(union_boxes([0.0, 1.0, 5.0, 6.0], [2.0, -1.0, 4.0, 9.0]), [0.0, -1.0, 5.0, 9.0])


def test_bad_input() -> None:
    T = look_at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="radius"):
        cylinder_bbox(PINHOLE, T, [1.0, 0.0, 0.0], 0.0, 0.1, np.eye(3))
    with pytest.raises(ValueError, match="half_height"):
        cylinder_bbox(PINHOLE, T, [1.0, 0.0, 0.0], 0.05, -0.1, np.eye(3))
    with pytest.raises(ValueError, match="half_sides"):
        cuboid_bbox(PINHOLE, T, [1.0, 0.0, 0.0], [0.05, 0.05], np.eye(3))
    with pytest.raises(InputError, match="n_contour"):
        circle_bbox_optical(PINHOLE, [0.0, 0.0, 1.0], 0.05, np.eye(3), n_contour=2)


@pytest.mark.parametrize("camera", [PINHOLE, DISTORTED], ids=["pinhole", "distorted"])
def test_fit_recovers_an_upright_cylinder(camera: Camera) -> None:
    rng = np.random.default_rng(15)
    target = np.array([0.6, 0.0, 0.3])
    centre = target + rng.uniform(-0.01, 0.01, 3)
    poses = views(rng, target, 3)
    boxes = cylinder_bbox(camera, poses, centre, 0.025, 0.06, rotation_upright(0.0))
    fit = fit_ellipsoid_to_boxes(camera, poses, boxes, shape="cylinder", box_sigma=0.02)
    assert_allclose(fit.ellipsoid.centre_base, centre, atol=1e-5)
    assert_allclose(fit.ellipsoid.semi_axes, [0.025, 0.025, 0.06], atol=1e-5)


def test_fit_recovers_a_yawed_cuboid_and_bic_picks_the_solid() -> None:
    rng = np.random.default_rng(16)
    target = np.array([0.6, 0.0, 0.3])
    centre = target + rng.uniform(-0.01, 0.01, 3)
    poses = views(rng, target, 6)
    boxes = cuboid_bbox(PINHOLE, poses, centre, [0.025, 0.025, 0.06], rotation_upright(0.4))
    best, fits = fit_shape_by_bic(PINHOLE, poses, boxes, shapes=("spheroid", "ellipsoid", "cylinder", "cuboid"), box_sigma=0.02)
    assert best.model == "cuboid"
    assert_allclose(best.ellipsoid.centre_base, centre, atol=1e-5)
    assert_allclose(np.sort(best.ellipsoid.semi_axes), [0.025, 0.025, 0.06], atol=1e-5)
    assert np.linalg.norm(fits["spheroid"].ellipsoid.centre_base - centre) > 1e-3  # the ellipsoid models are biased
