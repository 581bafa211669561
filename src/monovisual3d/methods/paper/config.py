"""Options of the ``paper`` method (:class:`PaperConfig`); numpy-free at import, so the CLI starts fast."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ...checks import is_real
from ...errors import InputError
from ...limits import DEFAULT_KEEP_THRESHOLD, DEFAULT_MAX_BYTES, DEFAULT_REACH_M


@dataclass(frozen=True)
class PaperConfig:
    """Options of the paper's method.

    Attributes
    ----------
    kernel : {"gaussian", "square"}
    sigma_fraction : float, Gaussian sigma as a fraction of box width/height (paper: 1/2; 1/3 with noise)
    resolution : float, grid cell size, metres
    reach : float, manipulator reach R, metres (grid cube of side 2R when no workspace is given)
    centre : {"weighted", "geometric"}
    k : "max" | "mode" | "min" | "last" | int, how many clusters (see :func:`choose_k`)
    keep_threshold : float, relative posterior threshold for the cells that are clustered
    weighted_kmeans : bool, use the posterior as k-means sample weights
    max_memory : int or str, bytes (or text such as 2GiB): memory budget; a grid that does not fit is refused
        with a resolution that fits
    backend : {"numpy", "numba", "torch"}, engine of the dense update: the numpy reference, the fused
        numba kernel (float32 posterior, see :mod:`monovisual3d.methods.paper.engine.dense`) or torch (``device``).
        Default ``"numba"`` (a core dependency); ``"numpy"`` is the readable reference the others are tested against.
    device : str or None, torch device ("cpu", "cuda"; None: cuda when available); backend "torch" only
    refine_to : float or None, metres: run the sparse coarse-to-fine path down to this resolution,
        with ``resolution`` as the root level (see :mod:`monovisual3d.methods.paper.engine.sparse`)
    threads : int or None, CPU threads of the compiled kernels (None: chosen by the amount of work)
    """

    kernel: str = "gaussian"
    sigma_fraction: float = 0.5
    resolution: float = 0.01
    reach: float = DEFAULT_REACH_M
    centre: str = "weighted"
    k: str | int = "max"
    keep_threshold: float = DEFAULT_KEEP_THRESHOLD
    weighted_kmeans: bool = False
    max_memory: int | str = DEFAULT_MAX_BYTES
    backend: str = "numba"
    device: str | None = None
    refine_to: float | None = None
    threads: int | None = None

    def __post_init__(self) -> None:
        from ...grid import _check_resolution
        from ..options import check_shared_options
        from .engine.params import check_kernel
        from .kmeans import CENTRES, choose_k

        check_shared_options(self)
        check_kernel(self.kernel)
        if not (self.sigma_fraction > 0):
            raise InputError(f"sigma_fraction: got {self.sigma_fraction}, expected a positive fraction of the box size")
        # Validate every option up front: otherwise a bad centre/k/threshold only surfaces after the
        # whole filter has run, and not at all when no view has a detection.
        _check_resolution(self.resolution)
        if not (is_real(self.reach) and math.isfinite(self.reach) and self.reach > 0):
            raise InputError(f"reach: got {self.reach!r}, expected a positive number of metres")
        if self.centre not in CENTRES:
            raise InputError(f"centre: got {self.centre!r}, expected one of {list(CENTRES)}")
        if not (is_real(self.keep_threshold) and 0.0 < self.keep_threshold <= 1.0):
            raise InputError(f"keep_threshold: got {self.keep_threshold!r}, expected a value in (0, 1]")
        choose_k([1], self.k)
        from .engine import check_backend

        check_backend(self.backend, self.device, self.refine_to, self.resolution)
