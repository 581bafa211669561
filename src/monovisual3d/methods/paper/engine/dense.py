"""Dense histogram updates with the fused numba kernel.

Two ways in:

- Functions that mirror the numpy reference one to one, used by
  :class:`monovisual3d.methods.paper.filter.HistogramFilter` when ``PaperConfig.backend ==
  "numba"``: :func:`paper_likelihood_fused` (twin of
  :func:`~monovisual3d.methods.paper.filter.paper_view_likelihood_grid`) and
  :func:`paper_update_fused` (twin of ``paper_update(prior,
  paper_view_likelihood_grid(...))``).
- :class:`DenseHistogramBatch`: the engine's own state, one or many grids in
  one buffer (float32 by default, linear or log space), with lazy
  normalisation so that each view costs a single pass over memory, and
  batching: many views of one grid, or many grids (sessions), in one kernel call.

Tolerance against the numpy reference (tested in ``tests/methods/paper/engine``): float64
storage agrees to ``rtol=1e-9`` plus the Gaussian cut-off (each cell's
likelihood is under-estimated by less than ``gauss_eps``, absolute); float32
storage to ``rtol=1e-5`` of the posterior maximum per view.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ....camera import Camera
from ....errors import InputError
from ....grid import VoxelGrid
from ....kernels.threads import kernel_threads
from ....session import View
from .params import DEFAULT_GAUSS_EPS, DEFAULT_TILE, PackedViews, concat_packed, pack_views, tile_counts

#: Single-thread cost of one cell in one view of :func:`numba_kernels.dense_update`, nanoseconds
#: (4.5-8 measured in CPU time on the 2 M-cell benchmark, six boxes per view, float32; the thread
#: count's work estimate: 2 M cells and three views get two threads, 0.25 M cells one).
NS_PER_CELL_VIEW = 5.0
#: Single-thread cost per cell of the normalisation passes (``scale_inplace``, ``exp_shift``), nanoseconds.
NS_PER_CELL_PASS = 1.0

#: What to install when numba is missing (numba is a core dependency of monovisual3d).
NUMBA_HINT = "pip install 'numba>=0.59' (a dependency of monovisual3d; reinstall it with pip install monovisual3d)"


def numba_kernels() -> ModuleType:
    """The compiled kernels module; an ImportError that says what to install when numba is missing."""
    try:
        import numba  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(f"numba is needed for backend 'numba' and the sparse path: {NUMBA_HINT}") from exc
    from . import numba_kernels as nk

    return nk


def _n_threads() -> int:
    import numba

    return int(numba.config.NUMBA_NUM_THREADS)


def _call_dense(
    nk: ModuleType,
    src: NDArray[Any],
    dst: NDArray[Any],
    *,
    inplace: bool,
    prior_one: bool,
    starts: NDArray[np.int64],
    shapes: NDArray[np.int64],
    resolutions: NDArray[np.float64],
    in_scale: NDArray[np.float64],
    log_space: bool,
    view_offsets: NDArray[np.int64],
    packed: PackedViews,
    tile: tuple[int, int, int],
    tile_live: NDArray[np.bool_] | None = None,
    precise: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Run :func:`numba_kernels.dense_update`; returns per-tile sums, maxima and tile offsets per grid."""
    n_tiles = np.array([int(np.prod(tile_counts(tuple(sh), tile))) for sh in shapes], dtype=np.int64)
    tile_offsets = np.zeros(len(shapes) + 1, dtype=np.int64)
    np.cumsum(n_tiles, out=tile_offsets[1:])
    if tile_live is None:
        tile_live = np.ones(tile_offsets[-1], dtype=np.bool_)
    tile_sum = np.empty(tile_offsets[-1])
    tile_max = np.empty(tile_offsets[-1])
    work_ns = NS_PER_CELL_VIEW * int(np.count_nonzero(tile_live)) * int(np.prod(tile)) * packed.n_views
    with kernel_threads(int(work_ns)):
        nk.dense_update(
            src,
            dst,
            inplace,
            prior_one,
            np.ascontiguousarray(starts, dtype=np.int64),
            np.ascontiguousarray(shapes, dtype=np.int64),
            np.ascontiguousarray(resolutions, dtype=np.float64),
            np.ascontiguousarray(in_scale, dtype=np.float64),
            log_space,
            view_offsets,
            packed,
            np.asarray(tile, dtype=np.int64),
            tile_offsets,
            tile_live,
            tile_sum,
            tile_max,
            _n_threads(),
            precise,
        )
    return tile_sum, tile_max, tile_offsets


def _single(grid: VoxelGrid) -> dict[str, NDArray[Any]]:
    return {
        "starts": np.zeros(1, dtype=np.int64),
        "shapes": np.asarray([grid.shape], dtype=np.int64),
        "resolutions": np.asarray([grid.resolution]),
    }


def paper_likelihood_fused(
    grid: VoxelGrid,
    camera: Camera,
    view: View,
    kernel: str = "gaussian",
    sigma_fraction: float = 0.5,
    *,
    gauss_eps: float = DEFAULT_GAUSS_EPS,
    tile: tuple[int, int, int] = DEFAULT_TILE,
) -> NDArray[np.float64]:
    """Per-view likelihood of every cell, flat (n_cells,), float64 (fused twin of the numpy reference).

    Agrees with :func:`monovisual3d.methods.paper.filter.paper_view_likelihood_grid` to ~1e-12
    relative, except that Gaussian terms below ``gauss_eps`` are dropped.

    Examples
    --------
    >>> from monovisual3d.session import Detection
    >>> g = VoxelGrid.from_bounds([-0.1, -0.1, 0.4], [0.1, 0.1, 0.6], 0.05)
    >>> v = View(np.eye(4), (Detection(np.array([200.0, 120.0, 440.0, 360.0])),))
    >>> lik = paper_likelihood_fused(g, Camera.from_hfov(640, 480, 69.0), v, "square")
    >>> lik.shape, float(lik.max())
    ((64,), 1.0)
    """
    nk = numba_kernels()
    packed = pack_views(grid, camera, [view], kernel, sigma_fraction, gauss_eps)
    out = np.empty(grid.n_cells)
    _call_dense(
        nk,
        out,
        out,
        inplace=False,
        prior_one=True,
        **_single(grid),
        in_scale=np.ones(1),
        log_space=False,
        view_offsets=np.array([0, 1], dtype=np.int64),
        packed=packed,
        tile=tile,
    )
    return out


def paper_update_fused(
    prior: NDArray[np.floating],
    grid: VoxelGrid,
    camera: Camera,
    views: View | Sequence[View],
    kernel: str = "gaussian",
    sigma_fraction: float = 0.5,
    *,
    gauss_eps: float = DEFAULT_GAUSS_EPS,
    dtype: Any = np.float32,
    tile: tuple[int, int, int] = DEFAULT_TILE,
) -> NDArray[Any] | None:
    """Fused twin of ``paper_update(prior, paper_view_likelihood_grid(...))`` for one or several views.

    Parameters
    ----------
    prior : ndarray, shape (n_cells,) or grid.shape, float32 or float64, sums to 1 (not modified)
    grid, camera : the grid and camera
    views : View or sequence of View, each with at least one detection. Several views are
        folded in one pass; the result equals the sequential updates unless one of them
        would have been skipped (then use one view per call).
    kernel, sigma_fraction : the paper's kernel options
    gauss_eps : Gaussian cut-off (see :mod:`monovisual3d.methods.paper.engine.params`)
    dtype : float32 (default) or float64, dtype of the returned posterior

    Returns
    -------
    posterior : ndarray, shape (n_cells,), ``dtype``, sums to 1; None where the product is
        zero everywhere (the view contradicts the prior), as :func:`~monovisual3d.methods.paper.filter.paper_update`.
    """
    nk = numba_kernels()
    views = [views] if isinstance(views, View) else list(views)
    src, dtype = _flat_prior(prior, grid, dtype)
    packed = pack_views(grid, camera, views, kernel, sigma_fraction, gauss_eps)
    dst = np.empty(grid.n_cells, dtype=dtype)
    tile_sum, _, _ = _call_dense(
        nk,
        src,
        dst,
        inplace=False,
        prior_one=False,
        **_single(grid),
        in_scale=np.ones(1),
        log_space=False,
        view_offsets=np.array([0, len(views)], dtype=np.int64),
        packed=packed,
        tile=tile,
        precise=dtype == np.float64,
    )
    total = float(tile_sum.sum())
    if not total > 0.0:
        return None
    with kernel_threads(int(NS_PER_CELL_PASS * dst.size)):
        nk.scale_inplace(dst, 1.0 / total)
    return dst


def _flat_prior(prior: NDArray[np.floating], grid: VoxelGrid, dtype: Any) -> tuple[NDArray[Any], np.dtype[Any]]:
    """The prior as a flat contiguous array of ``dtype`` (float32 or float64), checked against the grid."""
    src = np.ascontiguousarray(prior).reshape(-1)
    if src.dtype not in (np.float32, np.float64):
        src = src.astype(np.float64)
    if src.size != grid.n_cells:
        raise InputError(f"prior: has {src.size} cells, the grid has {grid.n_cells}")
    dtype = np.dtype(dtype)
    if dtype not in (np.float32, np.float64):
        raise InputError(f"dtype: got {dtype}, expected float32 or float64")
    if src.dtype != dtype:  # one compiled specialisation per dtype, not per (in, out) pair
        src = src.astype(dtype)
    return src, dtype


class DenseHistogramBatch:
    """Dense posteriors of one or more grids in one buffer, updated with one kernel call.

    Each grid starts uniform. The stored values are the posterior up to a
    factor (linear: the previous update's sum, divided out during the next
    update; log space: log values shifted by the previous maximum), so an update
    is one pass over memory. :meth:`posterior` normalises on request.

    Parameters
    ----------
    grids : VoxelGrid or sequence of VoxelGrid
    kernel, sigma_fraction : the paper's kernel options
    gauss_eps : Gaussian cut-off (see :mod:`monovisual3d.methods.paper.engine.params`)
    dtype : float32 (default, 4 bytes per cell) or float64
    log_space : store log posteriors (no underflow over many Gaussian views; slower)
    tile : tile size along (i, j, k)

    Examples
    --------
    >>> from monovisual3d.session import Detection
    >>> g = VoxelGrid.from_bounds([-0.1, -0.1, 0.4], [0.1, 0.1, 0.6], 0.01)
    >>> h = DenseHistogramBatch(g, kernel="square")
    >>> v = View(np.eye(4), (Detection(np.array([200.0, 120.0, 440.0, 360.0])),))
    >>> h.update(Camera.from_hfov(640, 480, 69.0), [[v]])
    [[True]]
    >>> round(float(h.posterior(0).sum()), 6)
    1.0
    """

    def __init__(
        self,
        grids: VoxelGrid | Sequence[VoxelGrid],
        *,
        kernel: str = "gaussian",
        sigma_fraction: float = 0.5,
        gauss_eps: float = DEFAULT_GAUSS_EPS,
        dtype: Any = np.float32,
        log_space: bool = False,
        tile: tuple[int, int, int] = DEFAULT_TILE,
    ) -> None:
        self.grids = [grids] if isinstance(grids, VoxelGrid) else list(grids)
        if not self.grids:
            raise InputError("grids: expected at least one VoxelGrid")
        self.nk = numba_kernels()
        self.kernel = kernel
        self.sigma_fraction = float(sigma_fraction)
        self.gauss_eps = float(gauss_eps)
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.float32, np.float64):
            raise InputError(f"dtype: got {self.dtype}, expected float32 or float64")
        self.log_space = bool(log_space)
        self.tile = tuple(int(t) for t in tile)
        n = [g.n_cells for g in self.grids]
        self.value_offsets = np.zeros(len(n) + 1, dtype=np.int64)
        np.cumsum(n, out=self.value_offsets[1:])
        self.shapes = np.asarray([g.shape for g in self.grids], dtype=np.int64)
        self.resolutions = np.asarray([g.resolution for g in self.grids])
        nt = [int(np.prod(tile_counts(g.shape, self.tile))) for g in self.grids]  # type: ignore[arg-type]
        self.tile_offsets = np.zeros(len(nt) + 1, dtype=np.int64)
        np.cumsum(nt, out=self.tile_offsets[1:])
        self.values = np.empty(self.value_offsets[-1], dtype=self.dtype)
        self.tile_live = np.empty(self.tile_offsets[-1], dtype=np.bool_)
        self._scale = np.empty(len(n))
        self._total = np.empty(len(n))
        self.accepted: list[list[tuple[Camera, View]]] = [[] for _ in self.grids]
        for s in range(len(self.grids)):
            self._reset(s)

    # ------------------------------------------------------------------ state
    def _reset(self, s: int) -> None:
        a, b = self.value_offsets[s], self.value_offsets[s + 1]
        self.values[a:b] = 0.0 if self.log_space else 1.0
        self.tile_live[self.tile_offsets[s] : self.tile_offsets[s + 1]] = True
        self._scale[s] = 0.0 if self.log_space else 1.0
        # linear: sum of stored values; log: log-sum-exp of stored values
        self._total[s] = np.log(b - a) if self.log_space else float(b - a)

    def reset(self) -> None:
        """Every grid back to uniform, forgetting all views."""
        for s in range(len(self.grids)):
            self._reset(s)
            self.accepted[s] = []

    @property
    def n_grids(self) -> int:
        return len(self.grids)

    @property
    def memory_bytes(self) -> int:
        """Bytes held by the state (values and tile bookkeeping)."""
        return int(self.values.nbytes + self.tile_live.nbytes + self._scale.nbytes + self._total.nbytes)

    def posterior(self, s: int = 0, dtype: Any = np.float64) -> NDArray[Any]:
        """Normalised posterior of grid ``s``, shape ``grids[s].shape``."""
        a, b = self.value_offsets[s], self.value_offsets[s + 1]
        v = self.values[a:b]
        if self.log_space:
            out = np.empty(b - a, dtype=dtype)
            with kernel_threads(int(5 * NS_PER_CELL_PASS * v.size)):  # exp: about 5x a multiply
                self.nk.exp_shift(v, self._total[s], out)
        else:
            out = v.astype(dtype)
            out /= out.dtype.type(self._total[s])
        return out.reshape(self.grids[s].shape)

    def log_posterior(self, s: int = 0) -> NDArray[np.float64]:
        """Normalised log posterior of grid ``s`` (``-inf`` for zero), shape ``grids[s].shape``, float64."""
        a, b = self.value_offsets[s], self.value_offsets[s + 1]
        v = self.values[a:b].astype(np.float64)
        with np.errstate(divide="ignore"):
            out = v - self._total[s] if self.log_space else np.log(v) - np.log(self._total[s])
        return out.reshape(self.grids[s].shape)

    # ------------------------------------------------------------------ update
    def _run(self, grid_ids: list[int], packs: list[PackedViews]) -> list[bool]:
        """One kernel call folding ``packs[n]`` into grid ``grid_ids[n]``; False where a grid became all zero."""
        packed, view_offsets = concat_packed(packs)
        starts = self.value_offsets[grid_ids]
        tile_live = np.concatenate([self.tile_live[self.tile_offsets[s] : self.tile_offsets[s + 1]] for s in grid_ids])
        floor = -np.inf if self.log_space else 0.0
        in_scale = self._scale[grid_ids]
        tile_sum, tile_max, toff = _call_dense(
            self.nk,
            self.values,
            self.values,
            inplace=True,
            prior_one=False,
            starts=starts,
            shapes=self.shapes[grid_ids],
            resolutions=self.resolutions[grid_ids],
            in_scale=in_scale,
            log_space=self.log_space,
            view_offsets=view_offsets,
            packed=packed,
            tile=self.tile,  # type: ignore[arg-type]
            tile_live=tile_live,
            precise=self.dtype == np.float64,
        )
        ok = []
        for n, s in enumerate(grid_ids):
            ts, tm = tile_sum[toff[n] : toff[n + 1]], tile_max[toff[n] : toff[n + 1]]
            self.tile_live[self.tile_offsets[s] : self.tile_offsets[s + 1]] = tm > floor
            m = float(tm.max())
            if not m > floor:
                ok.append(False)
                continue
            if self.log_space:
                live = tm > floor
                self._total[s] = m + float(np.log(np.sum(ts[live] * np.exp(tm[live] - m))))
                self._scale[s] = m
            else:  # stored values sum to 1 after the next update's in_scale: far from float32's limits
                self._total[s] = float(ts.sum())
                self._scale[s] = 1.0 / self._total[s]
            ok.append(True)
        return ok

    def _rebuild(self, s: int, camera: Camera, new_views: list[View]) -> list[bool]:
        """Sequential updates of grid ``s`` from uniform, skipping views that zero the posterior."""
        history = list(self.accepted[s])
        self.accepted[s] = []
        self._reset(s)
        for cam, view in history:
            self._run([s], [pack_views(self.grids[s], cam, [view], self.kernel, self.sigma_fraction, self.gauss_eps)])
            self.accepted[s].append((cam, view))
        used = []
        for view in new_views:
            pack = pack_views(self.grids[s], camera, [view], self.kernel, self.sigma_fraction, self.gauss_eps)
            if self._run([s], [pack])[0]:
                self.accepted[s].append((camera, view))
                used.append(True)
            else:
                used.append(False)
                keep = list(self.accepted[s])
                self.accepted[s] = []
                self._reset(s)
                for cam, v in keep:
                    self._run([s], [pack_views(self.grids[s], cam, [v], self.kernel, self.sigma_fraction, self.gauss_eps)])
                    self.accepted[s].append((cam, v))
        return used

    def update(self, cameras: Camera | Sequence[Camera], views_per_grid: Sequence[Sequence[View]]) -> list[list[bool]]:
        """Fold views into the grids, all in one kernel call.

        Parameters
        ----------
        cameras : Camera, or one Camera per grid
        views_per_grid : one sequence of View per grid (may be empty)

        Returns
        -------
        used : one list of bool per grid: whether each view changed the posterior. Views
            without detections are skipped, and so is a view that would make the posterior
            zero everywhere (then the grid is recomputed view by view, as the paper's filter does).
        """
        if len(views_per_grid) != self.n_grids:
            raise InputError(f"views_per_grid: got {len(views_per_grid)} lists, expected one per grid ({self.n_grids})")
        cams = [cameras] * self.n_grids if isinstance(cameras, Camera) else list(cameras)
        if len(cams) != self.n_grids:
            raise InputError(f"cameras: got {len(cams)}, expected one per grid ({self.n_grids})")
        used: list[list[bool]] = [[bool(v.detections) for v in views] for views in views_per_grid]
        ids, packs, with_boxes = [], [], []
        for s, views in enumerate(views_per_grid):
            vb = [v for v in views if v.detections]
            if vb:
                ids.append(s)
                packs.append(pack_views(self.grids[s], cams[s], vb, self.kernel, self.sigma_fraction, self.gauss_eps))
                with_boxes.append(vb)
        if not ids:
            return used
        ok = self._run(ids, packs)
        for s, good, vb in zip(ids, ok, with_boxes):
            if good:
                self.accepted[s].extend((cams[s], v) for v in vb)
                continue
            flags = iter(self._rebuild(s, cams[s], vb))
            used[s] = [next(flags) if u else False for u in used[s]]
        return used


class DenseHistogram(DenseHistogramBatch):
    """:class:`DenseHistogramBatch` of a single grid, with a one-grid :meth:`update`.

    Examples
    --------
    >>> from monovisual3d.session import Detection
    >>> g = VoxelGrid.from_bounds([-0.1, -0.1, 0.4], [0.1, 0.1, 0.6], 0.01)
    >>> h = DenseHistogram(g, kernel="gaussian")
    >>> v = View(np.eye(4), (Detection(np.array([200.0, 120.0, 440.0, 360.0])),))
    >>> h.update_views(Camera.from_hfov(640, 480, 69.0), [v, v])
    [True, True]
    """

    def __init__(self, grid: VoxelGrid, **options: Any) -> None:
        super().__init__([grid], **options)

    @property
    def grid(self) -> VoxelGrid:
        return self.grids[0]

    def update_views(self, camera: Camera, views: View | Sequence[View]) -> list[bool]:
        """Fold one or several views into the grid in one pass; see :meth:`DenseHistogramBatch.update`."""
        views = [views] if isinstance(views, View) else list(views)
        return self.update(camera, [views])[0]
