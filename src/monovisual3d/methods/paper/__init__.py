"""The ``paper`` method: MonoVisual3DFilter as published (Magalhães et al., Robotica 2024).

Layout (one module per step of the paper's Algorithm 1):

- :mod:`.config` — :class:`PaperConfig`, every option (numpy-free, so the CLI's ``--help`` stays light);
- :mod:`.kernels` — the per-box square and Gaussian kernels and the per-view mixture (numpy reference);
- :mod:`.filter` — the histogram filter over a voxel grid: :func:`paper_update` and the
  incremental :class:`HistogramFilter`; the fast twins of its update live in :mod:`monovisual3d.methods.paper.engine`;
- :mod:`.kmeans` — from the posterior to objects: :func:`choose_k` and :func:`kmeans_objects`;
- :mod:`.run` — :func:`run` on one session (dense, or the sparse coarse-to-fine path with ``refine_to``).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

#: Public name -> submodule; imported on first use so reading the config does not load numpy.
_LAZY = {
    "PaperConfig": "config",
    "HistogramFilter": "filter",
    "paper_update": "filter",
    "choose_k": "kmeans",
    "kmeans_objects": "kmeans",
    "run": "run",
}

__all__ = ["HistogramFilter", "PaperConfig", "choose_k", "kmeans_objects", "paper_update", "run"]

if TYPE_CHECKING:  # pragma: no cover
    from .config import PaperConfig
    from .filter import HistogramFilter, paper_update
    from .kmeans import choose_k, kmeans_objects
    from .run import run


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
