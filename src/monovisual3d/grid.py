"""Uniform voxel grids over the workspace.

A grid has its own frame ``grid``: cell ``(i, j, k)`` (indices along grid x,
y, z) has its centre at ``p_grid = ((i, j, k) + 0.5) * resolution``, and
``T_base_grid`` places the grid in the base frame. Flat cell indices follow
C order over ``(i, j, k)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import InputError
from .frames import transform_points

#: Default manipulator reach R (metres); the paper's grid is a cube of side 2R.
DEFAULT_REACH_M = 0.6
#: Working bytes per cell of the dense numpy filter (posterior + per-chunk temporaries, amortised).
BYTES_PER_CELL = 16
#: Largest grid the dense filter accepts by default.
DEFAULT_MAX_BYTES = 4 * 1024**3


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
        return math.prod(int(n) for n in self.shape)

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
    shape: tuple[int, ...], resolution: float, *, max_bytes: int = DEFAULT_MAX_BYTES, extent: str = "workspace"
) -> None:
    """Refuse a grid whose dense filter would not fit in ``max_bytes``; suggest a resolution.

    Counts in Python integers (no int64 overflow). The message names ``extent``
    (the parameter that set the grid's size: ``workspace`` or ``reach``) when no
    useful resolution would fit, else ``resolution``.
    """
    n = math.prod(int(v) for v in shape)
    need = n * BYTES_PER_CELL
    if need > max_bytes:
        factor = (need / max_bytes) ** (1 / 3)
        suggestion = resolution * factor * 1.05
        big = max(shape) >= 10**6
        dims = "x".join(f"{v:.3g}" if big else str(v) for v in shape)
        cells = f"{n:,}" if n < 10**12 else f"{float(n):.3g}"
        field = "resolution" if suggestion <= _COARSEST_USEFUL_M else extent
        raise InputError(
            f"{field}: a {resolution * 1000:.6g} mm grid has {cells} cells ({dims}) and needs about "
            f"{need / 1024**3:.4g} GiB, over the {max_bytes / 1024**3:.1f} GiB limit; use --resolution "
            f"{suggestion:.4g} or larger, or a smaller {extent}"
        )


def _check_resolution(resolution: float) -> None:
    if not isinstance(resolution, (int, float)) or not (resolution > 0 and math.isfinite(resolution)):
        raise InputError(f"resolution: got {resolution!r}, expected a positive number of metres")
