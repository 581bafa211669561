"""The ``bayes`` method: generative, size-aware box likelihood with explaining-away extraction.

:mod:`.pipeline` is the method, one ordered list of passes (:data:`.pipeline.PASSES`) over one state
(:mod:`.state`); :mod:`.localizer` its front ends, :class:`BayesLocalizer` (incremental) and :func:`run` (one session);
:mod:`.config` its options (:class:`BayesConfig`, with the sensor model :class:`SensorModel` and the developer knobs
:class:`~.config.BayesTuning` nested). ``docs/architecture.md`` lists the package module by module.

Ghosts (cone intersections of different fruit) lose: their implied sizes disagree between views and they have no box
in the other views, and once the real fruit have taken the boxes, nothing is left. With a stated pose uncertainty
(``pose_sigma_mm``, ``pose_sigma_deg``) the edge noise includes the pose error projected into pixels, and the spheres
are refined jointly with a pose correction per view (``Result.pose_corrections``).
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
