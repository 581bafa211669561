"""A small LfD array set written by the tests: simulated ellipsoids seen from a ring of views, boxes projected."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from monovisual3d import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.ellipsoid import Ellipsoid

#: Camera of the written set, our pixel convention (the files hold OpenCV's: principal point 0.5 px less).
CAMERA = Camera(640, 480, 520.0, 520.0, 320.0, 240.0)


def scene(rng: np.random.Generator, n_objects: int = 3, n_views: int = 5) -> tuple[list[Ellipsoid], np.ndarray]:
    """Upright ellipsoids (5-12 cm) spread on a table and ``T_base_optical`` (n, 4, 4) of a ring of views 0.7-0.9 m away."""
    objects = []
    for k in range(n_objects):
        centre = np.array([0.15 * (k - (n_objects - 1) / 2), rng.uniform(-0.05, 0.05), rng.uniform(0.05, 0.08)])
        semi = rng.uniform([0.025, 0.025, 0.05], [0.04, 0.045, 0.07])
        objects.append(Ellipsoid.upright(centre, semi, rng.uniform(0, np.pi)))
    poses = []
    for f in range(n_views):
        a = -1.1 + 2.2 * f / max(n_views - 1, 1) + rng.uniform(-0.1, 0.1)
        d = rng.uniform(0.7, 0.9)
        eye = np.array([d * np.cos(a), d * np.sin(a), rng.uniform(0.4, 0.6)])
        poses.append(look_at(eye, rng.uniform(-0.02, 0.02, 3)))
    return objects, np.array(poses)


def arrays(objects: list[Ellipsoid], T_base_optical: np.ndarray, camera: Camera = CAMERA) -> dict[str, np.ndarray]:
    """The LfD arrays (OpenCV pixels) of the scene: intrinsics, camera_poses, bounding_boxes, visibility, gt."""
    n, m = len(T_base_optical), len(objects)
    K = np.array([[camera.fx, 0.0, camera.cx - 0.5], [0.0, camera.fy, camera.cy - 0.5], [0.0, 0.0, 1.0]])
    poses = np.zeros((4 * n, 3))
    boxes = np.zeros((n, 4 * m))
    for f, T in enumerate(T_base_optical):
        T_ob = np.linalg.inv(T)
        poses[4 * f : 4 * f + 4] = T_ob[:3].T  # the transpose of [R | t]
        for j, e in enumerate(objects):
            boxes[f, 4 * j : 4 * j + 4] = e.bbox(camera, T, clip=False) - 0.5
    gt = np.stack([2.5 * e.dual_quadric() for e in objects])  # any scale
    return {"intrinsics": K, "camera_poses": poses, "bounding_boxes": boxes, "visibility": np.ones((n, m), bool), "gt": gt}


def write(folder: Path, data: dict[str, np.ndarray]) -> Path:
    """Write the arrays as ``NAME.npy`` into ``folder`` (created)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, a in data.items():
        np.save(folder / f"{name}.npy", a)
    return folder
