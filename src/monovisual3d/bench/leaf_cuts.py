"""The box edges that leaves cut in the accuracy benchmark's simulated fruit, and the simulator's edge-noise densities.

The ``greenhouse-noise`` bound of ``bench accuracy`` (:func:`monovisual3d.bench.accuracy.cut_crlb_rms_sq`) leaves
out every edge a leaf cuts, as if the estimator were told which ones. Studies of what not being told costs need, per
fruit, its true boxes, which edges are cut and how deep, and the density of the simulator's box noise:

- :func:`fruit_boxes`: every simulated fruit of a condition's seeds with its boxes (the simulator's association), its
  silhouette boxes and their Jacobians, its cut edges and their depths, and the known-cut bound;
- :data:`PAIR_COVARIANCE`, :func:`pair_noise_density`, :func:`edge_noise_density`: the simulator's noise of an axis's
  two edges (correlated: centre and size noise) and of one edge, in units of the edge's noise scale (``box_sigma``
  times the box's size along that axis).

Examples
--------
>>> ax, u, density = pair_noise_density(0.1, 6.0)
>>> u.shape == (len(ax), len(ax), 2), bool(abs(density.sum() * 0.1**2 - 1.0) < 1e-3)
(True, True)
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..geometry.bounds import BORDER_PX, cut_edges, ellipsoid_box_jacobian, ellipsoid_crlb
from ..sim.scenes import default_camera
from .accuracy import conditions, simulated_session

#: The simulator's edge-noise covariance of an axis's two edges, in units of (box_sigma * size)^2
#: (:func:`monovisual3d.geometry.bounds.box_edge_covariance`).
PAIR_COVARIANCE = np.array([[1.25, 0.75], [0.75, 1.25]])


def pair_noise_density(step: float, pad: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The density of an axis's two edge offsets under the box noise alone, on a grid.

    Parameters
    ----------
    step : float, grid step, noise-scale units
    pad : float, the grid spans ``[-pad, pad]`` on both axes, noise-scale units

    Returns
    -------
    ax : ndarray, shape (n,), the grid's points along one axis
    u : ndarray, shape (n, n, 2), the offsets of the two edges at each grid point
    density : ndarray, shape (n, n), the density (of :data:`PAIR_COVARIANCE`) at ``u``
    """
    ax = np.arange(-pad, pad + step / 2, step)
    u = np.stack(np.meshgrid(ax, ax, indexing="ij"), axis=-1)
    inv = np.linalg.inv(PAIR_COVARIANCE)
    density = np.exp(-0.5 * np.einsum("...i,ij,...j->...", u, inv, u)) / (2 * np.pi * np.sqrt(np.linalg.det(PAIR_COVARIANCE)))
    return ax, u, density


def edge_noise_density(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Density of one edge's offset ``x`` (noise-scale units) under the box noise alone.

    Examples
    --------
    >>> float(edge_noise_density(np.array([0.0]))[0].round(4))
    0.3568
    """
    var = PAIR_COVARIANCE[0, 0]
    return np.exp(-0.5 * x**2 / var) / np.sqrt(2 * np.pi * var)


@dataclass(frozen=True, eq=False)
class FruitBoxes:
    """One simulated fruit and the boxes it truly has (the simulator's association; views without its box left out).

    Attributes
    ----------
    seed, index : int, the scene's seed and the fruit's index in ``scene.fruits``
    ellipsoid : the fruit's true ellipsoid (``EllipsoidFruit.ellipsoid``)
    radius : float, metres, its radius in the scene
    T_base_optical : ndarray, shape (V, 4, 4), the true poses of the views that box it
    seen : ndarray, shape (V, 4), pixels, its visible boxes before noise
    boxes : ndarray, shape (V, 4), pixels, the detector's boxes (with noise)
    full : ndarray, shape (V, 4), pixels, its unoccluded silhouette boxes, unclipped
    J : ndarray, shape (V, 4, P), the derivatives of ``full`` with respect to the shape's P parameters
    usable : ndarray, shape (V, 4), bool, edges inside the image
    cut : ndarray, shape (V, 4), bool, edges an occluder cuts
    known_sq : float, m^2, the benchmark's known-cut bound (trace of the centre's bound)
    depths : ndarray, shape (U,), the usable edges' cut depths in noise-scale units (0: uncut)
    """

    seed: int
    index: int
    ellipsoid: Any
    radius: float
    T_base_optical: NDArray[np.float64]
    seen: NDArray[np.float64]
    boxes: NDArray[np.float64]
    full: NDArray[np.float64]
    J: NDArray[np.float64]
    usable: NDArray[np.bool_]
    cut: NDArray[np.bool_]
    known_sq: float
    depths: NDArray[np.float64]


def fruit_boxes(name: str, seeds: range) -> Iterator[FruitBoxes]:
    """Every fruit seen in some view of the condition ``name``'s sessions (``bench accuracy``) for ``seeds``.

    Examples
    --------
    >>> fruit = next(fruit_boxes("greenhouse-noise", range(0, 1)))
    >>> fruit.boxes.shape == fruit.full.shape == fruit.cut.shape
    True
    """
    cond = next((c for c in conditions(False) if c.name == name), None)
    if cond is None:
        raise InputError(f"condition: got {name!r}, expected one of {[c.name for c in conditions(False)]}")
    sigma, camera = cond.noise.box_sigma, default_camera()
    size = np.array([camera.width, camera.height], dtype=float)
    for seed in seeds:
        scene = cond.scene(seed)
        _, svs = simulated_session(scene, cond.noise, seed, masks=False)
        for f, obj in enumerate(scene.fruits):
            views = [sv for sv in svs if f in set(sv.source.tolist())]
            if not views:
                continue
            e = obj.ellipsoid
            T = np.array([sv.T_base_optical_true for sv in views])
            seen = np.array([sv.rendering.boxes_xyxy[f] for sv in views], dtype=float)
            boxes = np.array([np.asarray(sv.boxes_xyxy, dtype=float)[list(sv.source).index(f)] for sv in views])
            full, J = ellipsoid_box_jacobian(camera, T, e, e.shape)
            inside = np.concatenate([full[:, :2] > BORDER_PX, full[:, 2:] < size - BORDER_PX], axis=1)
            usable = np.isfinite(full) & inside & np.all(np.isfinite(J), axis=2)
            cut = cut_edges(full, seen)
            known = ellipsoid_crlb(camera, T, e, sigma, e.shape, censored=cut, noise_boxes_xyxy=seen).centre_rms_sq
            inward = np.concatenate([seen[:, :2] - full[:, :2], full[:, 2:] - seen[:, 2:]], axis=1)
            scale = sigma * np.concatenate([seen[:, 2:] - seen[:, :2]] * 2, axis=1)
            depths = np.where(cut, inward / scale, 0.0)[usable]
            yield FruitBoxes(seed, f, e, float(scene.radii[f]), T, seen, boxes, full, J, usable, cut, float(known), depths)
