"""The timed cases of the update benchmarks: the paper's scene, its cube, and one runner per engine.

Scene: the paper's six spheres seen from its three poses (:func:`monovisual3d.sim.scenes.paper_scene`,
:func:`~monovisual3d.sim.viewpoints.paper_poses`), exact boxes; the grid is the paper's cube of side
:data:`CUBE_M` in front of the first camera. The naive per-cell loop (Algorithm 1 in pure Python) is
written here on purpose with scalars and ``math``, as a Python port of the paper would be: it is the
baseline the engines are compared with, not a second home of the projection.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..camera import Camera
from ..grid import VoxelGrid
from ..methods.paper.kernels import paper_cell_likelihood
from ..session import Detection, View

#: Side of the paper's cube, metres (2 x reach 0.6 m).
CUBE_M = 1.2
#: The paper's box-kernel width, a fraction of the box size (its sigma_fraction).
SIGMA_FRACTION = 0.5
#: ``max_bytes`` of the benchmark grids: 1 TiB, i.e. no limit here (each engine allocates only what it times).
NO_GRID_LIMIT_BYTES = 2**40


def bench_scene(n_views: int = 3, n_boxes: int = 6, seed: int = 0) -> tuple[Camera, list[View]]:
    """The paper's scene and poses with exact boxes; more views/boxes for the scaling runs.

    Views beyond the paper's three look at the target from random points 0.5 m
    away (within 30 degrees of the first view's axis). Boxes beyond the six
    spheres' are copies of them shifted by up to 40 px (so that every box is
    like a fruit's); fewer boxes keep the first ``n_boxes``.
    """
    from ..frames import look_at
    from ..geometry.sphere import sphere_bbox
    from ..sim.scenes import default_camera, paper_scene
    from ..sim.viewpoints import DEFAULT_TARGET, paper_poses

    rng = np.random.default_rng(seed)
    camera = default_camera()
    scene = paper_scene()
    poses = list(paper_poses())
    target = np.asarray(DEFAULT_TARGET, dtype=float)
    axis = (target - poses[0][:3, 3]) / np.linalg.norm(target - poses[0][:3, 3])
    while len(poses) < n_views:
        d = axis + rng.normal(scale=0.3, size=3)
        d /= np.linalg.norm(d)
        poses.append(look_at(target - 0.5 * d, target))
    views = []
    for T in poses[:n_views]:
        boxes = sphere_bbox(camera, T, scene.centres, scene.radii)
        boxes = boxes[np.all(np.isfinite(boxes), axis=1)]
        extra = []
        while len(boxes) + len(extra) < n_boxes:
            b = boxes[len(extra) % len(boxes)] + np.repeat(rng.uniform(-40, 40, 2), 2)[[0, 2, 1, 3]]
            extra.append(np.clip(b, 0, [camera.width, camera.height] * 2))
        allb = np.concatenate([boxes, np.asarray(extra).reshape(-1, 4)])[:n_boxes]
        views.append(View(T, tuple(Detection(b) for b in allb)))
    return camera, views


def paper_grid(views: list[View], edge: int) -> VoxelGrid:
    """The paper's cube in front of the first view, ``edge**3`` cells."""
    return VoxelGrid.in_front_of_camera(views[0].T_base_optical, CUBE_M / edge, CUBE_M / 2, max_bytes=NO_GRID_LIMIT_BYTES)


def naive_update(
    prior: np.ndarray, grid: VoxelGrid, camera: Camera, view: View, kernel: str, sigma_fraction: float, cells: np.ndarray
) -> float:
    """Algorithm 1 as a per-cell pure-Python loop over ``cells`` (flat indices); returns the partial normaliser.

    Transform to the optical frame, pinhole projection with distortion, the
    mean of the box kernels, multiply by the prior: written well (scalars and
    ``math``, no numpy per cell), as a Python port of the paper would be.
    """
    from ..frames import invert_transform

    T = (invert_transform(view.T_base_optical) @ grid.T_base_grid).tolist()
    fx, fy, cx, cy = camera.fx, camera.fy, camera.cx, camera.cy
    model, d = camera.distortion_model, list(camera.distortion_coefficients) + [0.0] * 8
    boxes = view.boxes_xyxy.tolist()
    ni, nj, nk = grid.shape
    res = grid.resolution
    total = 0.0
    for c in cells.tolist():
        i, rem = divmod(c, nj * nk)
        j, k = divmod(rem, nk)
        gx, gy, gz = (i + 0.5) * res, (j + 0.5) * res, (k + 0.5) * res
        z = T[2][0] * gx + T[2][1] * gy + T[2][2] * gz + T[2][3]
        if z <= 0:
            continue
        x = (T[0][0] * gx + T[0][1] * gy + T[0][2] * gz + T[0][3]) / z
        y = (T[1][0] * gx + T[1][1] * gy + T[1][2] * gz + T[1][3]) / z
        if model in ("plumb_bob", "rational_polynomial"):
            r2 = x * x + y * y
            radial = 1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]))
            if model == "rational_polynomial":
                radial /= 1 + r2 * (d[5] + r2 * (d[6] + r2 * d[7]))
            x, y = (
                x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x),
                y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y,
            )
        u, v = fx * x + cx, fy * y + cy
        p = prior[c] * paper_cell_likelihood(u, v, boxes, kernel, sigma_fraction)
        prior[c] = p
        total += p
    return total


def run_naive(grid: VoxelGrid, camera: Camera, views: list[View], kernel: str, cells: np.ndarray, prior: np.ndarray) -> None:
    for v in views:
        naive_update(prior, grid, camera, v, kernel, SIGMA_FRACTION, cells)


def run_numpy(grid: VoxelGrid, camera: Camera, views: list[View], kernel: str) -> None:
    from ..methods.paper.filter import paper_update, paper_view_likelihood_grid

    p: Any = np.full(grid.n_cells, 1.0 / grid.n_cells)
    for v in views:
        p = paper_update(p, paper_view_likelihood_grid(grid, camera, v, kernel, SIGMA_FRACTION))


def run_filter_path(grid: VoxelGrid, camera: Camera, views: list[View], kernel: str) -> None:
    from ..methods.paper.engine.dense import paper_update_fused

    p: Any = np.full(grid.n_cells, 1.0 / grid.n_cells, dtype=np.float32)
    for v in views:
        p = paper_update_fused(p, grid, camera, v, kernel, SIGMA_FRACTION)


def run_sparse(grid: VoxelGrid, packed: Any, levels: int, threshold: float, out: dict[str, Any]) -> None:
    from ..methods.paper.engine.sparse import refine

    out["s"] = refine(grid, packed, levels, threshold=threshold)


def run_state(h: Any, camera: Camera, views: list[View], one_pass: bool) -> None:
    h.reset()
    if one_pass:
        h.update_views(camera, views)
    else:
        for v in views:
            h.update_views(camera, v)


def run_torch(h: Any, camera: Camera, views: list[View]) -> None:
    h.values.fill_(1.0 / h.grid.n_cells)
    for v in views:
        h.update_views(camera, v)
    if h.device.type == "cuda":
        import torch

        torch.cuda.synchronize()
