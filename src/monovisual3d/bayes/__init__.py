"""The ``bayes`` method: generative, size-aware box likelihood with explaining-away extraction."""

from __future__ import annotations

from .likelihood import SensorModel
from .method import BayesConfig, BayesLocalizer, localize_bayes

__all__ = ["BayesConfig", "BayesLocalizer", "SensorModel", "localize_bayes"]
