"""Geometry of the 3D view: points on image planes, ellipsoid meshes, error ellipsoids, polylines.

Positions are metres in the base frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # pragma: no cover
    from ...camera import Camera

#: chi-square quantile of 3 degrees of freedom at 95 %: the 95 % ellipsoid is ``d^T C^-1 d <= CHI2_3DOF_95``.
CHI2_3DOF_95 = 7.814727903251178


def image_plane_points(
    camera: Camera, T_base_optical: NDArray[np.float64], uv: NDArray[np.float64], depth: float
) -> NDArray[np.float64]:
    """Points at optical depth ``depth`` along the viewing rays of pixels ``uv``.

    Parameters
    ----------
    camera : Camera
    T_base_optical : ndarray, shape (4, 4)
    uv : ndarray, shape (N, 2), pixels
    depth : float, metres along the optical axis (z of the optical frame)

    Returns
    -------
    p_base : ndarray, shape (N, 3), metres, base frame

    Examples
    --------
    >>> from monovisual3d.camera import Camera
    >>> cam = Camera.from_hfov(640, 480, 90.0)
    >>> image_plane_points(cam, np.eye(4), np.array([[320.0, 240.0]]), 2.0).round(6).tolist()
    [[0.0, 0.0, 2.0]]
    """
    d_optical = camera.rays(np.asarray(uv, dtype=float).reshape(-1, 2))
    p_optical = d_optical * (depth / d_optical[:, 2:3])
    return p_optical @ T_base_optical[:3, :3].T + T_base_optical[:3, 3]


def ellipsoid_mesh(
    centre: NDArray[np.float64],
    semi_axes: NDArray[np.float64],
    R: NDArray[np.float64] | None = None,
    n_lat: int = 10,
    n_lon: int = 16,
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Triangle mesh of the ellipsoid ``centre + R diag(semi_axes) s`` over the unit sphere ``s``.

    Returns
    -------
    vertices : ndarray, shape (V, 3), metres
    faces : ndarray, shape (F, 3), vertex indices

    Examples
    --------
    >>> v, f = ellipsoid_mesh(np.zeros(3), np.array([1.0, 2.0, 3.0]))
    >>> np.abs(v).max(axis=0).round(6).tolist()
    [1.0, 2.0, 3.0]
    """
    lat = np.linspace(0.0, np.pi, n_lat + 1)
    lon = np.linspace(0.0, 2 * np.pi, n_lon, endpoint=False)
    s = np.stack(
        [np.outer(np.sin(lat), np.cos(lon)), np.outer(np.sin(lat), np.sin(lon)), np.outer(np.cos(lat), np.ones_like(lon))],
        axis=-1,
    ).reshape(-1, 3)
    R = np.eye(3) if R is None else R
    vertices = (s * semi_axes) @ R.T + centre
    a = np.arange(n_lat)[:, None] * n_lon
    b = np.arange(n_lon)[None, :]
    i00, i01 = a + b, a + (b + 1) % n_lon
    i10, i11 = i00 + n_lon, i01 + n_lon
    faces = np.concatenate([np.stack([i00, i10, i11], -1).reshape(-1, 3), np.stack([i00, i11, i01], -1).reshape(-1, 3)])
    return vertices, faces


def error_ellipsoid_axes(
    covariance: NDArray[np.float64], chi2: float = CHI2_3DOF_95
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Semi-axes (3,) in metres and axes rotation (3, 3) of ``{d : d^T C^-1 d <= chi2}``.

    Examples
    --------
    >>> a, R = error_ellipsoid_axes(np.diag([1e-4, 4e-4, 9e-4]), chi2=1.0)
    >>> a.round(6).tolist()
    [0.01, 0.02, 0.03]
    """
    C = 0.5 * (covariance + covariance.T)
    w, V = np.linalg.eigh(C)
    if np.linalg.det(V) < 0:
        V[:, 0] = -V[:, 0]
    return np.sqrt(np.clip(w, 0.0, None) * chi2), V


def polyline(segments: Sequence[NDArray[np.float64]]) -> tuple[list[float | None], list[float | None], list[float | None]]:
    """x, y, z lists of several polylines (each shape (K, 3)) separated by None (plotly's line breaks)."""
    xs: list[float | None] = []
    ys: list[float | None] = []
    zs: list[float | None] = []
    for seg in segments:
        for p in seg:
            xs.append(float(p[0]))
            ys.append(float(p[1]))
            zs.append(float(p[2]))
        xs.append(None)
        ys.append(None)
        zs.append(None)
    return xs, ys, zs


def mm(p: NDArray[np.float64]) -> str:
    """A position (3,) in metres as ``"(x, y, z) mm"``, whole millimetres."""
    return "(" + ", ".join(f"{1000 * v:.0f}" for v in p) + ") mm"
