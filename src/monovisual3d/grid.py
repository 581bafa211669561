"""Uniform voxel grids over the workspace.

A grid has its own frame ``grid``: cell ``(i, j, k)`` (indices along grid x,
y, z) has its centre at ``p_grid = ((i, j, k) + 0.5) * resolution``, and
``T_base_grid`` places the grid in the base frame. Flat cell indices follow
C order over ``(i, j, k)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .checks import format_bytes
from .errors import InputError
from .frames import invert_transform, transform_points
from .limits import DEFAULT_MAX_BYTES, DEFAULT_REACH_M

if TYPE_CHECKING:
    from .camera import Camera
    from .session import View

#: Working bytes per cell of the paper's dense filter: posterior and likelihood (float64), the compiled engine's
#: float32 copy, and k-means coordinates and weights when every cell survives the threshold.
BYTES_PER_CELL = 48


@dataclass(frozen=True)
class VoxelGrid:
    """A uniform grid of cubic cells.

    Parameters
    ----------
    T_base_grid : ndarray, shape (4, 4)
        Pose of the grid frame in the base frame (may be rotated).
    shape : tuple of int
        Number of cells ``(ni, nj, nk)`` along grid x, y, z.
    resolution : float
        Cell edge length, metres.

    Examples
    --------
    >>> g = VoxelGrid.from_bounds([0, 0, 0], [0.1, 0.1, 0.1], 0.05)
    >>> g.shape, g.n_cells
    ((2, 2, 2), 8)
    """

    T_base_grid: NDArray[np.float64]
    shape: tuple[int, int, int]
    resolution: float

    @property
    def n_cells(self) -> int:
        return math.prod(int(v) for v in self.shape)

    @property
    def size_m(self) -> NDArray[np.float64]:
        """Extent along grid x, y, z, metres, shape (3,)."""
        return np.asarray(self.shape, dtype=float) * self.resolution

    @classmethod
    def from_bounds(
        cls, min_base: ArrayLike, max_base: ArrayLike, resolution: float, *, max_bytes: int = DEFAULT_MAX_BYTES
    ) -> VoxelGrid:
        """Axis-aligned grid covering ``[min_base, max_base]`` (metres, base frame)."""
        lo = np.asarray(min_base, dtype=float)
        hi = np.asarray(max_base, dtype=float)
        _check_resolution(resolution)
        with np.errstate(over="ignore", invalid="ignore"):  # an infinite extent is refused just below
            cells = (hi - lo) / resolution
        if lo.shape != (3,) or hi.shape != (3,) or not np.all(np.isfinite(cells)):
            raise InputError(f"workspace: min {lo.tolist()} and max {hi.tolist()} must be 3 finite coordinates, metres")
        shape = tuple(int(max(1, math.ceil(c - 1e-9))) for c in cells)
        check_grid_size(shape, resolution, max_bytes=max_bytes, extent="workspace")
        T = np.eye(4)
        T[:3, 3] = lo
        return cls(T, shape, float(resolution))  # type: ignore[arg-type]

    @classmethod
    def in_front_of_camera(
        cls,
        T_base_optical: ArrayLike,
        resolution: float,
        reach: float = DEFAULT_REACH_M,
        *,
        max_bytes: int = DEFAULT_MAX_BYTES,
    ) -> VoxelGrid:
        """The paper's decomposition: a cube of side ``2 * reach`` in front of the camera.

        Centred on the optical axis, from the camera out to ``2 * reach`` along
        it; the grid axes are the optical frame's axes.
        """
        _check_resolution(resolution)
        if not (reach > 0 and math.isfinite(reach)):
            raise InputError(f"reach: got {reach}, expected a positive number of metres")
        cells = 2 * reach / resolution
        if not math.isfinite(cells):
            raise InputError(f"reach: got {reach}, too large for a {resolution} m resolution")
        n = int(math.ceil(cells - 1e-9))
        shape = (n, n, n)
        check_grid_size(shape, resolution, max_bytes=max_bytes, extent="reach")
        offset = np.eye(4)
        half = 0.5 * n * resolution  # = reach when 2 * reach is a whole number of cells; keeps the axis centred otherwise
        offset[:3, 3] = [-half, -half, 0.0]
        return cls(np.asarray(T_base_optical, dtype=float) @ offset, shape, float(resolution))

    def centres_grid(self, flat_index: ArrayLike | None = None) -> NDArray[np.float64]:
        """Cell centres in the grid frame, shape (N, 3), metres."""
        if flat_index is None:
            flat_index = np.arange(self.n_cells)
        ijk = np.stack(np.unravel_index(np.asarray(flat_index), self.shape), axis=-1)
        return (ijk + 0.5) * self.resolution

    def centres_base(self, flat_index: ArrayLike | None = None) -> NDArray[np.float64]:
        """Cell centres in the base frame, shape (N, 3), metres."""
        return transform_points(self.T_base_grid, self.centres_grid(flat_index))

    def to_dict(self) -> dict[str, Any]:
        return {
            "T_base_grid": self.T_base_grid.tolist(),
            "shape": list(self.shape),
            "resolution_m": self.resolution,
            "n_cells": self.n_cells,
        }


#: A suggested resolution coarser than this (metres) is useless for fruit: the extent is blamed instead.
_COARSEST_USEFUL_M = 0.1


def check_grid_size(
    shape: tuple[int, ...],
    resolution: float,
    *,
    max_bytes: int = DEFAULT_MAX_BYTES,
    bytes_per_cell: int = BYTES_PER_CELL,
    extent: str = "workspace",
) -> None:
    """Refuse a grid whose dense filter would not fit in ``max_bytes``; the error suggests a resolution that fits.

    Counts in Python integers (no int64 overflow). The suggestion is checked: a grid over the same
    extent at the suggested resolution passes this check. The message names ``extent`` (the parameter
    that set the grid's size: ``workspace`` or ``reach``) when no useful resolution would fit, else
    ``resolution``.
    """
    n = math.prod(int(v) for v in shape)
    need = n * bytes_per_cell
    if need <= max_bytes:
        return
    sizes = [int(v) * resolution for v in shape]

    def cells(res: float) -> int:
        return math.prod(max(1, math.ceil(e / res - 1e-9)) for e in sizes)

    suggestion = float(f"{resolution * (need / max_bytes) ** (1 / 3):.3g}")
    while cells(suggestion) * bytes_per_cell > max_bytes:
        suggestion = float(f"{suggestion * 1.05:.3g}")
    big = max(shape) >= 10**6
    dims = "x".join(f"{v:.3g}" if big else str(v) for v in shape)
    count = f"{n:,}" if n < 10**12 else f"{float(n):.3g}"
    field = "resolution" if suggestion <= _COARSEST_USEFUL_M else extent
    raise InputError(
        f"{field}: a {resolution * 1000:.6g} mm grid has {count} cells ({dims}) and needs about {format_bytes(need)}, "
        f"over the max_memory budget of {format_bytes(max_bytes)}; resolution {suggestion:.4g} m fits, "
        f"or use a smaller {extent} or a larger max_memory"
    )


def _check_resolution(resolution: float) -> None:
    if not isinstance(resolution, (int, float)) or not (resolution > 0 and math.isfinite(resolution)):
        raise InputError(f"resolution: got {resolution!r}, expected a positive number of metres")


# ------------------------------------------------------------- viewing cones
#: The eight child offsets of an octree split, in units of the child cell size.
_CHILD_OFFSETS = np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5) for k in (-0.5, 0.5)])


def cone_counts(
    camera: Camera, views: list[View], centres_base: NDArray[np.floating], half_diagonal: float, widen: float = 0.5
) -> NDArray[np.int32]:
    """In how many views each point projects inside a (widened) box.

    Parameters
    ----------
    camera : Camera
    views : list of View (views without detections count for nothing)
    centres_base : ndarray, shape (N, 3), metres, base frame
    half_diagonal : float, metres: radius of the region each point stands for
    widen : float, boxes are widened by this fraction of their size on each side

    Returns
    -------
    counts : ndarray, shape (N,), int32
    """
    counts = np.zeros(len(centres_base), dtype=np.int32)
    f = max(camera.fx, camera.fy)
    for view in views:
        boxes = view.boxes_xyxy
        if len(boxes) == 0:
            continue
        p_opt = transform_points(invert_transform(view.T_base_optical), centres_base)
        z = p_opt[:, 2]
        front = z > 1e-6
        uv = camera.project(p_opt)
        with np.errstate(divide="ignore", invalid="ignore"):
            margin = np.where(front, f * half_diagonal / np.maximum(z, 1e-6), np.inf) + 2.0
        inside = np.zeros(len(centres_base), dtype=bool)
        # a point whose region reaches behind the camera gets the benefit of the doubt
        near = (z > -half_diagonal) & ~front
        for x1, y1, x2, y2 in boxes:
            wx, wy = widen * (x2 - x1), widen * (y2 - y1)
            u, v = uv[:, 0], uv[:, 1]
            inside |= (u >= x1 - wx - margin) & (u <= x2 + wx + margin) & (v >= y1 - wy - margin) & (v <= y2 + wy + margin)
        counts += (inside | near).astype(np.int32)
    return counts


def cell_half_diagonal(size: float) -> float:
    """Half the space diagonal of a cubic cell of side ``size`` (metres): every point of the cell lies within it of the
    centre, so a cell whose centre's projection is that far (at its depth) from a box may still touch the box's cone.

    Examples
    --------
    >>> round(cell_half_diagonal(0.02), 5)
    0.01732
    """
    return size * math.sqrt(3) / 2


def split_cells(centres_grid: NDArray[np.floating], size: float) -> NDArray[np.float64]:
    """Octree split: the 8 children (cell size ``size / 2``) of each cell centre, shape (8N, 3).

    The children of input row ``i`` are output rows ``8 i`` to ``8 i + 7``.
    """
    child = size / 2
    return (centres_grid[:, None, :] + _CHILD_OFFSETS[None, :, :] * child).reshape(-1, 3)


def child_rows(parents: NDArray[np.integer]) -> NDArray[np.intp]:
    """Rows of :func:`split_cells`'s output holding the children of the input rows ``parents`` (P,), shape (8P,).

    Examples
    --------
    >>> child_rows(np.array([0, 2])).tolist()
    [0, 1, 2, 3, 4, 5, 6, 7, 16, 17, 18, 19, 20, 21, 22, 23]
    """
    return (8 * np.asarray(parents, dtype=np.intp)[:, None] + np.arange(8)).ravel()
