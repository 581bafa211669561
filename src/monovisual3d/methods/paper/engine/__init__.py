"""Fast engines for the histogram update: fused numba kernels, a sparse coarse-to-fine path, torch.

Modules (each imports its heavy dependency only when used):

- :mod:`.params`: views, boxes and grids packed as flat arrays (numpy only; shared by all backends).
- :mod:`.numba_kernels`: the fused, parallel CPU kernels (numba, a core dependency).
- :mod:`.dense`: dense updates with the numba kernels: the twins of the numpy reference used by
  ``PaperConfig(backend="numba")``, and :class:`~.dense.DenseHistogramBatch` (many views, many grids).
- :mod:`.sparse`: coarse-to-fine updates on an active set of cells (``PaperConfig(refine_to=...)``).
- :mod:`.torch_backend`: the dense update with torch tensors on CPU or CUDA (extra ``[gpu]``).

The readable references stay in :mod:`monovisual3d.methods.paper.kernels` and :mod:`monovisual3d.methods.paper.filter`.
"""

from __future__ import annotations

BACKENDS = ("numpy", "numba", "torch")

from typing import TYPE_CHECKING, Any  # noqa: E402

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np
    from numpy.typing import NDArray

    from ....camera import Camera
    from ....grid import VoxelGrid
    from ....session import View


def check_backend(backend: str, device: str | None = None, refine_to: float | None = None, resolution: float = 1.0) -> None:
    """Validate the engine options of :class:`~monovisual3d.methods.paper.config.PaperConfig` (no heavy import).

    Examples
    --------
    >>> check_backend("numba")
    >>> check_backend("cupy")
    Traceback (most recent call last):
    ...
    monovisual3d.errors.InputError: backend: got 'cupy', expected one of ['numpy', 'numba', 'torch']
    """
    import math

    from ....checks import is_real
    from ....errors import InputError

    if backend not in BACKENDS:
        raise InputError(f"backend: got {backend!r}, expected one of {list(BACKENDS)}")
    if device is not None and backend != "torch":
        raise InputError(f"device: {device!r} applies to backend 'torch' only (got backend {backend!r})")
    if device is not None and not (isinstance(device, str) and device.split(":")[0] in ("cpu", "cuda")):
        raise InputError(f"device: got {device!r}, expected 'cpu', 'cuda' or 'cuda:N'")
    if refine_to is not None:
        if not (is_real(refine_to) and math.isfinite(refine_to) and refine_to > 0):
            raise InputError(f"refine_to: got {refine_to!r}, expected a positive number of metres")
        if refine_to > resolution:
            raise InputError(f"refine_to: {refine_to} m is coarser than resolution {resolution} m (the root level)")


def likelihood_grid(
    grid: VoxelGrid, camera: Camera, view: View, kernel: str, sigma_fraction: float, *, backend: str, device: str | None = None
) -> NDArray[np.float64]:
    """Per-view likelihood of every cell with a fast backend (twin of ``paper_view_likelihood_grid``)."""
    if backend == "numba":
        from .dense import paper_likelihood_fused

        return paper_likelihood_fused(grid, camera, view, kernel, sigma_fraction)
    if backend == "torch":
        from .torch_backend import paper_likelihood_torch

        return paper_likelihood_torch(grid, camera, view, kernel, sigma_fraction, device=device).cpu().numpy()
    check_backend(backend)
    raise ValueError(f"backend {backend!r} has no fast engine")  # pragma: no cover - numpy is handled by the caller


def paper_update_backend(prior: NDArray[Any], grid: VoxelGrid, camera: Camera, view: View, config: Any) -> NDArray[Any] | None:
    """One step of :class:`~monovisual3d.methods.paper.filter.HistogramFilter` with ``config.backend`` (numba or torch).

    Returns the normalised posterior as a new float32 array (flat), or None where the view
    contradicts the prior, as :func:`~monovisual3d.methods.paper.filter.paper_update`.
    """
    if config.backend == "numba":
        from .dense import paper_update_fused

        return paper_update_fused(prior, grid, camera, view, config.kernel, config.sigma_fraction)
    if config.backend == "torch":
        from .torch_backend import paper_update_torch

        return paper_update_torch(prior, grid, camera, view, config.kernel, config.sigma_fraction, device=config.device)
    check_backend(config.backend)
    raise ValueError(f"backend {config.backend!r} has no fast engine")  # pragma: no cover
