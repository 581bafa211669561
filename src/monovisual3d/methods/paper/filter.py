"""The paper's histogram filter (MonoVisual3DFilter), dense numpy reference.

Pure functions do the maths (:func:`project_grid`, :func:`paper_update`); the
:class:`HistogramFilter` class holds the state (grid and posterior) for
incremental use on a robot: create it, call :meth:`HistogramFilter.update` as
each view arrives, and read :attr:`HistogramFilter.posterior` or
:meth:`HistogramFilter.estimate` at any time.
"""

from __future__ import annotations

import warnings
from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from ...errors import InputError, InputWarning
from ...frames import invert_transform, transform_points
from ...grid import VoxelGrid, cell_half_diagonal, cone_counts
from ...result import DetectedObject
from ...session import View, Workspace
from .config import PaperConfig
from .kernels import paper_view_likelihood
from .kmeans import choose_k, kmeans_objects

#: Cells processed per chunk by the numpy reference (bounds temporaries to ~100 MB).
CHUNK_CELLS = 1 << 20


def project_grid(
    grid: VoxelGrid, camera: Camera, T_base_optical: NDArray[np.floating], flat_index: NDArray[np.integer] | None = None
) -> NDArray[np.float64]:
    """Project cell centres into a view.

    Returns
    -------
    uv : ndarray, shape (N, 2), pixels; NaN for cells behind the camera
    """
    T_optical_grid = invert_transform(T_base_optical) @ grid.T_base_grid
    p_optical = transform_points(T_optical_grid, grid.centres_grid(flat_index))
    return camera.project(p_optical)


def paper_view_likelihood_grid(
    grid: VoxelGrid,
    camera: Camera,
    view: View,
    kernel: str,
    sigma_fraction: float,
    chunk: int = CHUNK_CELLS,
    *,
    backend: str = "numpy",
) -> NDArray[np.float64]:
    """The per-view likelihood of every cell, flat (n_cells,), not yet normalised.

    ``backend="numba"`` or ``"torch"`` use the fast engine (:mod:`monovisual3d.methods.paper.engine`); this
    function's numpy code is the reference they are tested against.
    """
    if backend != "numpy":
        from .engine import likelihood_grid

        return likelihood_grid(grid, camera, view, kernel, sigma_fraction, backend=backend)
    boxes = view.boxes_xyxy
    out = np.empty(grid.n_cells)
    for start in range(0, grid.n_cells, chunk):
        idx = np.arange(start, min(start + chunk, grid.n_cells))
        uv = project_grid(grid, camera, view.T_base_optical, idx)
        out[idx] = paper_view_likelihood(uv, boxes, kernel, sigma_fraction)
    return out


def paper_update(prior: NDArray[np.floating], likelihood: NDArray[np.floating]) -> NDArray[np.float64] | None:
    """One Bayes step of the paper (Algorithm 1): normalise, multiply, normalise.

    Returns None when the product is zero everywhere (the view contradicts the
    prior), so that the caller can decide what to do.

    Examples
    --------
    >>> paper_update(np.ones(4) / 4, np.array([0.0, 1.0, 1.0, 0.5]))
    array([0. , 0.4, 0.4, 0.2])
    """
    m = likelihood.max()
    if m <= 0:
        return None
    post = prior * (likelihood / m)
    s = post.sum()
    if s <= 0:
        return None
    return post / s


def view_sees_grid(grid: VoxelGrid, camera: Camera, view: View, step: int = 4) -> bool:
    """Whether any grid cell can project into one of the view's boxes (checked on every ``step``-th cell per axis)."""
    sub = [np.arange(0, n, step) for n in grid.shape]
    ijk = np.stack(np.meshgrid(*sub, indexing="ij"), axis=-1).reshape(-1, 3)
    centres = transform_points(grid.T_base_grid, (ijk + 0.5) * grid.resolution)
    return bool(cone_counts(camera, [view], centres, cell_half_diagonal(step * grid.resolution), widen=0.0).any())


class HistogramFilter:
    """Incremental histogram filter over a voxel grid (the paper's method).

    Parameters
    ----------
    camera : Camera
    config : PaperConfig
    grid : VoxelGrid, optional
        Fixed grid. Without it, the grid comes from ``workspace`` or, failing
        that, from the paper's policy at the first view with a detection.
    workspace : Workspace, optional
    keep_history : bool
        Keep a copy of the posterior after every view (for figures).

    Examples
    --------
    >>> from monovisual3d import load_session
    >>> f = HistogramFilter(Camera.from_hfov(640, 480, 69))
    >>> f.posterior is None  # no grid until the first view with a detection
    True
    """

    def __init__(
        self,
        camera: Camera,
        config: PaperConfig | None = None,
        *,
        grid: VoxelGrid | None = None,
        workspace: Workspace | None = None,
        keep_history: bool = False,
    ) -> None:
        self.camera = camera
        self.config = config or PaperConfig()
        self.grid = grid
        if grid is None and workspace is not None:
            self.grid = VoxelGrid.from_bounds(
                workspace.min, workspace.max, self.config.resolution, max_bytes=int(self.config.max_memory)
            )
        self._posterior: NDArray[np.float64] | None = None
        if self.grid is not None:
            self._posterior = np.full(self.grid.n_cells, 1.0 / self.grid.n_cells)
        self.detection_counts: list[int] = []
        self.views_used: list[int] = []
        self.messages: list[str] = []
        self.history: list[NDArray[np.float64]] | None = [] if keep_history else None
        self._n_seen = 0

    @property
    def posterior(self) -> NDArray[np.float64] | None:
        """Posterior over cells, shape grid.shape, sums to 1 (None before the grid exists)."""
        if self._posterior is None or self.grid is None:
            return None
        return self._posterior.reshape(self.grid.shape)

    def _warn(self, message: str) -> None:
        self.messages.append(message)
        warnings.warn(InputWarning(message), stacklevel=3)

    def update(self, view: View) -> bool:
        """Fold one view into the posterior. Returns True if the view changed it.

        A view with no detections is skipped (the paper's mixture is undefined
        for N = 0), and so is a view whose boxes no cell projects into or that
        contradicts all previous views; each skip is reported as a warning.
        """
        index = self._n_seen
        self._n_seen += 1
        if not view.detections:
            self._warn(f"views[{index}]: no detections, skipped by the paper method")
            return False
        if self.grid is None:
            self.grid = VoxelGrid.in_front_of_camera(
                view.T_base_optical, self.config.resolution, self.config.reach, max_bytes=int(self.config.max_memory)
            )
            self._posterior = np.full(self.grid.n_cells, 1.0 / self.grid.n_cells)
        assert self._posterior is not None
        if not view_sees_grid(self.grid, self.camera, view):
            self._warn(
                f"views[{index}]: none of this view's boxes looks into the grid (workspace); view skipped "
                "(check the workspace, pose units (metres) and quaternion order (x, y, z, w))"
            )
            return False
        if self.config.backend != "numpy":
            from .engine import paper_update_backend

            post = paper_update_backend(self._posterior, self.grid, self.camera, view, self.config)
        else:
            lik = paper_view_likelihood_grid(self.grid, self.camera, view, self.config.kernel, self.config.sigma_fraction)
            post = paper_update(self._posterior, lik)
        if post is None:
            self._warn(f"views[{index}]: no grid cell is consistent with this view's boxes and the previous views; view skipped")
            return False
        self._posterior = post
        self.detection_counts.append(len(view.detections))
        self.views_used.append(index)
        if self.history is not None:
            self.history.append(post.copy())
        return True

    def estimate(self, **overrides: Any) -> list[DetectedObject]:
        """Current object estimates (k-means over the surviving cells).

        Keyword arguments override :class:`PaperConfig` fields for this call
        (``centre``, ``k``, ``keep_threshold``, ``weighted_kmeans``).
        """
        unknown = sorted(set(overrides) - {"centre", "k", "keep_threshold", "weighted_kmeans"})
        if unknown:  # a misspelt option (e.g. "center") must not be silently ignored
            raise InputError(f"{unknown[0]}: not an estimate option, expected centre, k, keep_threshold or weighted_kmeans")
        if self.grid is None or self._posterior is None or not self.views_used:
            return []
        cfg = {**asdict(self.config), **overrides}
        k = choose_k(self.detection_counts, cfg["k"])
        posterior = self._posterior
        if posterior.dtype != np.float64:  # float32 from the compiled engines: make the masses sum to 1 in float64
            posterior = posterior.astype(np.float64)
            posterior /= posterior.sum()
        return kmeans_objects(
            self.grid,
            posterior,
            k,
            centre=cfg["centre"],
            keep_threshold=cfg["keep_threshold"],
            weighted_kmeans=cfg["weighted_kmeans"],
        )
