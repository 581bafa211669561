"""The parameters of the ``bayes`` box likelihood (:class:`SensorModel`); no numpy, so options load fast."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ...errors import InputError


@dataclass(frozen=True)
class SensorModel:
    """Parameters of the box likelihood (see the module docstring).

    Attributes
    ----------
    alpha : float, edge noise as a fraction of the predicted box size
    sigma0_px : float, edge noise floor in pixels (quantisation)
    inward_floor : float, nats: the most an edge inside the prediction (occlusion) can cost
    outward_floor : float, nats: the most an edge outside the prediction can cost
    match_bonus : float, nats: log-ratio of a perfectly matching box vs. no object
    p_miss : float, probability that a visible object yields no box (missed or hidden)
    border_px : float, an observed edge within this distance of the image border is censored
    """

    alpha: float = 0.05
    sigma0_px: float = 1.0
    inward_floor: float = 3.0
    outward_floor: float = 6.0
    match_bonus: float = 8.0
    p_miss: float = 0.1
    border_px: float = 1.0

    def __post_init__(self) -> None:
        if not 0 < self.p_miss < 1:
            raise InputError(f"p_miss: got {self.p_miss}, expected a probability in (0, 1)")
        if self.alpha < 0 or self.sigma0_px <= 0:
            raise InputError("alpha must be >= 0 and sigma0_px > 0")

    @property
    def miss_term(self) -> float:
        return math.log(self.p_miss)
