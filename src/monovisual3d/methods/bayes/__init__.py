"""The ``bayes`` method: generative, size-aware box likelihood with explaining-away extraction.

Layout (a pipeline of pure functions over frozen data):

- :mod:`.config` — :class:`BayesConfig`, every option and switch;
- :mod:`.likelihood` — the sensor model: predicted boxes, edge likelihood, miss term;
- :mod:`.problem` — the frozen inputs of one estimate, and the ``taken`` set of explained boxes;
- :mod:`.scoring` — scoring and fitting one object (:mod:`.refine`, :mod:`.masks`);
- :mod:`.search` -> :mod:`.extract` -> :mod:`.associate` -> :mod:`.bundle`: the stages,
  run in order by :func:`.pipeline.estimate`;
- :mod:`.localizer` — :class:`BayesLocalizer` (incremental) and :func:`run` (one session);
- :mod:`._kernels` — the fused numba kernels, tested against the numpy references.

Ghosts (cone intersections of different fruit) lose: their implied sizes
disagree between views and they have no box in the other views, and once the
real fruit have taken the boxes, nothing is left. With a stated pose
uncertainty (``pose_sigma_mm``, ``pose_sigma_deg``) the edge noise includes the
pose error projected into pixels, and all objects are refined jointly with a
pose correction per view (``Result.pose_corrections``).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

#: Public name -> submodule; imported on first use so reading the config does not load the kernels.
_LAZY = {"BayesConfig": "config", "SensorModel": "sensor", "BayesLocalizer": "localizer", "run": "localizer"}

__all__ = sorted(_LAZY)

if TYPE_CHECKING:  # pragma: no cover
    from .config import BayesConfig
    from .localizer import BayesLocalizer, run
    from .sensor import SensorModel


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
