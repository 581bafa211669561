"""Former home of the ``bayes`` method, kept so ``monovisual3d.bayes.BayesLocalizer`` keeps working.

The method lives in :mod:`monovisual3d.methods.bayes`.
"""

from __future__ import annotations

from ..methods.bayes import BayesConfig, BayesLocalizer, SensorModel, run

__all__ = ["BayesConfig", "BayesLocalizer", "SensorModel", "run"]
