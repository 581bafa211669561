"""Flat arrays that describe views, boxes and grids to the fast kernels (numpy only).

The numba and torch kernels take no Python objects: this module packs a
:class:`~monovisual3d.session.View` list, a :class:`~monovisual3d.camera.Camera`
and a :class:`~monovisual3d.grid.VoxelGrid` into plain float64/int64 arrays.
Everything here is backend independent and importable without numba or torch.

Kernel parameters per box (``box_params``, shape (B, 4), float64):

- square (id 0): ``x1, y1, x2, y2`` in pixels;
- gaussian (id 1): ``cu, cv, a, b`` with ``k = exp(-(a du^2 + b dv^2))``,
  ``a = 1 / (2 sx^2)``, ``b = 1 / (2 sy^2)``.

``box_reach`` (B, 4) is the pixel rectangle outside which the box's kernel is
(treated as) zero: the box itself for the square kernel; for the Gaussian the
ellipse ``a du^2 + b dv^2 <= q_cut`` of the cut-off, where
``q_cut = -ln(gauss_eps)``.

Error bound of the Gaussian cut-off
-----------------------------------
A box term is skipped only where ``a du^2 + b dv^2 > q_cut``, that is where
the term is below ``gauss_eps``. The mixture is the mean of the N terms, so the
likelihood of every cell is under-estimated by less than ``gauss_eps``
(absolute, on a kernel whose peak is 1): ``L - gauss_eps < L_fast <= L``.
With the default ``gauss_eps = 1e-12`` that is far below float32 resolution.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ....camera import Camera
from ....errors import InputError
from ....frames import invert_transform
from ....grid import VoxelGrid
from ....session import View

#: Kernel ids understood by the fast kernels (the paper's Eq. 3 and Eq. 4).
KERNEL_IDS = {"square": 0, "gaussian": 1}
#: Kernel names, in id order.
KERNELS = tuple(KERNEL_IDS)
#: Default Gaussian cut-off: box terms below this value are skipped (see the module docstring).
DEFAULT_GAUSS_EPS = 1e-12
#: Default tile of the dense kernels, cells along grid (i, j, k); k is the contiguous axis.
DEFAULT_TILE = (4, 4, 32)


def check_kernel(kernel: str) -> None:
    """Raise :class:`~monovisual3d.errors.InputError` unless ``kernel`` is one of :data:`KERNELS`.

    Examples
    --------
    >>> check_kernel("gaussian")
    """
    if kernel not in KERNELS:
        raise InputError(f"kernel: got {kernel!r}, expected one of {list(KERNELS)}")


def gauss_q_cut(gauss_eps: float) -> float:
    """The cut-off on ``a du^2 + b dv^2`` for a relative error ``gauss_eps``.

    Examples
    --------
    >>> round(gauss_q_cut(1e-12), 3)
    27.631
    """
    if not (1e-18 <= gauss_eps < 1.0):
        raise InputError(f"gauss_eps: got {gauss_eps}, expected a value in [1e-18, 1)")
    return -math.log(gauss_eps)


class PackedViews(NamedTuple):
    """Views of one or more grids as flat arrays (V views, B boxes in all).

    Attributes
    ----------
    T_optical_grid : ndarray, shape (V, 3, 4), float64, rotation and translation, grid -> optical
    intrinsics : ndarray, shape (V, 4), float64, ``fx, fy, cx, cy`` in pixels
    distortion_id : ndarray, shape (V,), int64, see :data:`monovisual3d.camera.DISTORTION_IDS`
    distortion : ndarray, shape (V, 8), float64, coefficients as :meth:`monovisual3d.camera.Camera.packed`
    kernel_id : ndarray, shape (V,), int64, see :data:`KERNEL_IDS`
    inv_n : ndarray, shape (V,), float64, 1 / number of boxes (the mixture weight)
    box_offsets : ndarray, shape (V + 1,), int64, boxes of view v are ``box_offsets[v]:box_offsets[v + 1]``
    box_params : ndarray, shape (B, 4), float64, per-kernel parameters (module docstring)
    box_reach : ndarray, shape (B, 4), float64, pixels, ``x1, y1, x2, y2`` of the kernel's support
    q_cut : float, Gaussian cut-off on the squared normalised distance

    A named tuple, so that the compiled kernels take it whole (numba types a named tuple of arrays
    and reads its fields by name) rather than field by field.
    """

    T_optical_grid: NDArray[np.float64]
    intrinsics: NDArray[np.float64]
    distortion_id: NDArray[np.int64]
    distortion: NDArray[np.float64]
    kernel_id: NDArray[np.int64]
    inv_n: NDArray[np.float64]
    box_offsets: NDArray[np.int64]
    box_params: NDArray[np.float64]
    box_reach: NDArray[np.float64]
    q_cut: float

    @property
    def n_views(self) -> int:
        return int(self.T_optical_grid.shape[0])

    @property
    def max_boxes(self) -> int:
        """Largest number of boxes in one view (0 without views)."""
        return int(np.diff(self.box_offsets).max()) if self.n_views else 0


def box_params_from_xyxy(
    boxes_xyxy: NDArray[np.floating], kernel: str, sigma_fraction: float, q_cut: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Kernel parameters and support rectangles of boxes.

    Parameters
    ----------
    boxes_xyxy : ndarray, shape (N, 4), pixels
    kernel : {"square", "gaussian"}
    sigma_fraction : float, Gaussian sigma as a fraction of the box size
    q_cut : float, see :func:`gauss_q_cut`

    Returns
    -------
    box_params : ndarray, shape (N, 4), float64
    box_reach : ndarray, shape (N, 4), float64, pixels

    Examples
    --------
    >>> p, r = box_params_from_xyxy(np.array([[0.0, 0.0, 10.0, 20.0]]), "gaussian", 0.5, 2.0)
    >>> p.round(3).tolist(), r.round(3).tolist()
    ([[5.0, 10.0, 0.02, 0.005]], [[-5.0, -10.0, 15.0, 30.0]])
    """
    check_kernel(kernel)
    boxes = np.asarray(boxes_xyxy, dtype=np.float64).reshape(-1, 4)
    if kernel == "square":
        return boxes.copy(), boxes.copy()
    x1, y1, x2, y2 = boxes.T
    sx = sigma_fraction * (x2 - x1)
    sy = sigma_fraction * (y2 - y1)
    cu, cv = 0.5 * (x1 + x2), 0.5 * (y1 + y2)
    params = np.stack([cu, cv, 1.0 / (2 * sx * sx), 1.0 / (2 * sy * sy)], axis=1)
    hu = sx * math.sqrt(2 * q_cut)
    hv = sy * math.sqrt(2 * q_cut)
    reach = np.stack([cu - hu, cv - hv, cu + hu, cv + hv], axis=1)
    return params, reach


def pack_views(
    grid: VoxelGrid,
    camera: Camera,
    views: Sequence[View],
    kernel: str = "gaussian",
    sigma_fraction: float = 0.5,
    gauss_eps: float = DEFAULT_GAUSS_EPS,
) -> PackedViews:
    """Pack views that all have at least one box for the fast kernels.

    Parameters
    ----------
    grid : VoxelGrid, the grid whose cells are updated
    camera : Camera
    views : sequence of View, each with at least one detection
    kernel : {"square", "gaussian"}
    sigma_fraction : float
    gauss_eps : float, Gaussian cut-off (see the module docstring)

    Returns
    -------
    PackedViews
    """
    check_kernel(kernel)
    q_cut = gauss_q_cut(gauss_eps)
    n = len(views)
    T = np.empty((n, 3, 4))
    counts = np.empty(n, dtype=np.int64)
    params, reach = [], []
    for v, view in enumerate(views):
        boxes = view.boxes_xyxy
        if len(boxes) == 0:
            raise InputError("pack_views: every view needs at least one box (the paper's mixture is undefined for N = 0)")
        T[v] = (invert_transform(view.T_base_optical) @ grid.T_base_grid)[:3]
        counts[v] = len(boxes)
        p, r = box_params_from_xyxy(boxes, kernel, sigma_fraction, q_cut)
        params.append(p)
        reach.append(r)
    offsets = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    cam = camera.packed()
    return PackedViews(
        T_optical_grid=T,
        intrinsics=np.tile(cam.intrinsics, (n, 1)),
        distortion_id=np.full(n, cam.distortion_id, dtype=np.int64),
        distortion=np.tile(cam.distortion, (n, 1)),
        kernel_id=np.full(n, KERNEL_IDS[kernel], dtype=np.int64),
        inv_n=1.0 / counts.astype(np.float64),
        box_offsets=offsets,
        box_params=np.concatenate(params) if params else np.zeros((0, 4)),
        box_reach=np.concatenate(reach) if reach else np.zeros((0, 4)),
        q_cut=q_cut,
    )


def concat_packed(packs: Sequence[PackedViews]) -> tuple[PackedViews, NDArray[np.int64]]:
    """Concatenate the packed views of several grids (for one multi-session kernel call).

    Returns
    -------
    packed : PackedViews, all views in order
    view_offsets : ndarray, shape (len(packs) + 1,), int64, views of grid s are ``view_offsets[s]:view_offsets[s + 1]``
    """
    if not packs:
        raise InputError("concat_packed: nothing to concatenate")
    q = {p.q_cut for p in packs}
    if len(q) != 1:
        raise InputError("concat_packed: all packs must use the same gauss_eps")
    view_offsets = np.zeros(len(packs) + 1, dtype=np.int64)
    np.cumsum([p.n_views for p in packs], out=view_offsets[1:])
    box_counts = np.concatenate([np.diff(p.box_offsets) for p in packs])
    box_offsets = np.zeros(len(box_counts) + 1, dtype=np.int64)
    np.cumsum(box_counts, out=box_offsets[1:])
    packed = PackedViews(
        T_optical_grid=np.concatenate([p.T_optical_grid for p in packs]),
        intrinsics=np.concatenate([p.intrinsics for p in packs]),
        distortion_id=np.concatenate([p.distortion_id for p in packs]),
        distortion=np.concatenate([p.distortion for p in packs]),
        kernel_id=np.concatenate([p.kernel_id for p in packs]),
        inv_n=np.concatenate([p.inv_n for p in packs]),
        box_offsets=box_offsets,
        box_params=np.concatenate([p.box_params for p in packs]),
        box_reach=np.concatenate([p.box_reach for p in packs]),
        q_cut=packs[0].q_cut,
    )
    return packed, view_offsets


def tile_counts(shape: tuple[int, int, int], tile: tuple[int, int, int] = DEFAULT_TILE) -> tuple[int, int, int]:
    """Number of tiles along grid (i, j, k) for a grid ``shape`` and a tile size."""
    return tuple(-(-int(n) // int(t)) for n, t in zip(shape, tile))  # type: ignore[return-value]
