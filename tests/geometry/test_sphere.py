"""Bounding boxes of sphere silhouettes (the synthetic detections of the tests and examples)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d import Camera
from monovisual3d.frames import invert_transform, look_at, transform_points
from monovisual3d.geometry.sphere import clip_boxes, sphere_bbox, sphere_bbox_optical


def surface_box(camera: Camera, centre: np.ndarray, radius: float, n: int = 200_000, seed: int = 0) -> np.ndarray:
    """Box of the projection of many points on the sphere: a slightly-inside estimate of the exact box."""
    v = np.random.default_rng(seed).normal(size=(n, 3))
    uv = camera.project(centre + radius * v / np.linalg.norm(v, axis=1, keepdims=True))
    return np.concatenate([uv.min(0), uv.max(0)])


def test_hand_computed_box_on_axis() -> None:
    cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    half = 500.0 * math.tan(math.asin(0.1))  # tangent cone half-angle asin(r / d)
    assert_allclose(sphere_bbox_optical(cam, [0.0, 0.0, 1.0], 0.1), [320 - half, 240 - half, 320 + half, 240 + half], rtol=1e-12)


def test_off_axis_box_is_asymmetric_and_exact(rng: np.random.Generator) -> None:
    cam = Camera(640, 480, 500.0, 480.0, 321.0, 239.0)
    for _ in range(5):
        c = np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.2, 0.2), rng.uniform(0.6, 1.2)])
        box = sphere_bbox_optical(cam, c, 0.04, clip=False)
        ref = surface_box(cam, c, 0.04)
        assert np.all(box[:2] <= ref[:2] + 1e-9) and np.all(box[2:] >= ref[2:] - 1e-9)  # contains every surface point
        assert_allclose(box, ref, atol=0.05)  # and is tight


@pytest.mark.parametrize(
    ("model", "coeffs"), [("plumb_bob", (-0.2, 0.05, 0.001, -0.002, 0.01)), ("equidistant", (0.1, -0.05, 0.01, -0.002))]
)
def test_box_with_distortion_matches_projected_surface(model: str, coeffs: tuple[float, ...]) -> None:
    cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0, model, coeffs)
    c = np.array([0.15, -0.1, 0.8])
    assert_allclose(sphere_bbox_optical(cam, c, 0.05, clip=False), surface_box(cam, c, 0.05), atol=0.1)


def test_base_frame_version_and_batch(rng: np.random.Generator) -> None:
    cam = Camera.from_hfov(640, 480, 69.0)
    T = look_at([0.1, 0.2, 0.4], [0.6, 0.0, 0.45])
    centres = np.array([0.6, 0.0, 0.45]) + rng.uniform(-0.05, 0.05, (4, 3))
    radii = np.array([0.02, 0.03, 0.025, 0.035])
    boxes = sphere_bbox(cam, T, centres, radii)
    assert boxes.shape == (4, 4)
    assert_allclose(boxes, sphere_bbox_optical(cam, transform_points(invert_transform(T), centres), radii))
    assert_allclose(boxes[1], sphere_bbox(cam, T, centres[1], 0.03))


def test_sphere_behind_or_around_the_camera_is_nan() -> None:
    cam = Camera.from_hfov(640, 480, 69.0)
    boxes = sphere_bbox_optical(cam, [[0, 0, -1.0], [0, 0, 0.05], [0, 0, 1.0]], 0.1)
    assert np.all(np.isnan(boxes[:2])) and np.all(np.isfinite(boxes[2]))


def test_clipping() -> None:
    boxes = np.array([[-10.0, 20.0, 50.0, 500.0], [700.0, 10.0, 800.0, 20.0], [10.0, 10.0, 20.0, 20.0]])
    clipped = clip_boxes(boxes, 640, 480)
    assert_allclose(clipped[0], [0.0, 20.0, 50.0, 480.0])
    assert np.all(np.isnan(clipped[1]))
    assert_allclose(clipped[2], boxes[2])
    assert_allclose(boxes[0], [-10.0, 20.0, 50.0, 500.0])  # input untouched
    cam = Camera.from_hfov(640, 480, 69.0)
    assert np.all(np.isnan(sphere_bbox_optical(cam, [5.0, 0.0, 1.0], 0.1)))  # far right of the image
    assert np.all(np.isfinite(sphere_bbox_optical(cam, [5.0, 0.0, 1.0], 0.1, clip=False)))
