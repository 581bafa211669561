"""Options of the next-view planner (:class:`PlannerConfig`), checked on construction."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..checks import is_int, is_real
from ..errors import InputError
from ..methods.bayes.sensor import SensorModel


@dataclass(frozen=True)
class PlannerConfig:
    """Options of :func:`plan_next_view` (see the module docstring for the model).

    Attributes
    ----------
    target_mm : float, stopping rule: largest semi-axis of every object's 95 % position ellipsoid, millimetres
    motion_weight : float, gain (mm) lost per metre of camera travel (0: motion is free)
    rotation_scale_m : float, metres of travel one radian of camera rotation counts as
    p_occluder : float, prior probability that an unknown occluder hides an object in a view
    p_occluder_seen : float, the same towards directions in which the object was seen occluded or missed
    occluder_angle_deg : float, angular width (1 sigma) of that raised prior, degrees
    min_visible_fraction : float, visible part of the predicted disc below which no detection is expected
    occluded_edge_sigma : float, an observed edge this many sigmas inside the prediction counts as occluded
    discovery_weight : float, weight of the gain on tentative objects (unexplained boxes)
    coverage_mm : float, gain of newly covering the whole workspace volume seen by fewer than two views
    cap_mm : float, RMS position error beyond which an object counts as not localised, millimetres
    prior_radius_m : float, radius assumed for a tentative object, metres
    prior_radius_std_m : float, prior std of that radius, metres
    border_px : float, a predicted edge within this distance of the image border is cut
    coverage_points : int, workspace sample points per axis for the coverage term
    reach_m : float, arm-reach sphere radius around ``base_centre``: candidates outside are never picked
    base_centre : tuple, metres, base frame, centre of the reach sphere
    box_noise : float, ``"auto"`` or None, the detector's edge noise as a fraction of the box size.
        ``"auto"`` (default): estimated from how well the current estimate predicts the boxes seen so far
        (:func:`estimate_box_noise`, at least ``min_box_noise``); None: the sensor model's ``alpha``. The information and the stopping rule use it: the method's covariance
        is scaled by the ratio of the position variances under the stated and the model's edge noise
    min_box_noise : float, floor of the ``"auto"`` box noise (a few views cannot show less)
    joint_confidence : bool, stopping rule: the 95 % holds for all fruit together (each fruit's
        ellipsoid at the ``0.95 ** (1 / n)`` quantile, see :func:`stop_scale`); False: for each fruit alone
    sensor : SensorModel, the ``bayes`` method's sensor model (edge noise ``alpha * size + sigma0_px``)
    """

    target_mm: float = 5.0
    motion_weight: float = 0.0
    rotation_scale_m: float = 0.1
    p_occluder: float = 0.15
    p_occluder_seen: float = 0.7
    occluder_angle_deg: float = 15.0
    min_visible_fraction: float = 0.3
    occluded_edge_sigma: float = 2.5
    discovery_weight: float = 1.0
    coverage_mm: float = 10.0
    cap_mm: float = 30.0
    prior_radius_m: float = 0.03
    prior_radius_std_m: float = 0.015
    border_px: float = 1.0
    coverage_points: int = 8
    reach_m: float = math.inf
    base_centre: tuple[float, float, float] = (0.0, 0.0, 0.0)
    box_noise: float | str | None = "auto"
    joint_confidence: bool = True
    min_box_noise: float = 0.01
    sensor: SensorModel = field(default_factory=SensorModel)

    def __post_init__(self) -> None:
        for name in ("target_mm", "rotation_scale_m", "cap_mm", "prior_radius_m", "prior_radius_std_m", "occluder_angle_deg"):
            v = getattr(self, name)
            if not (is_real(v) and math.isfinite(v) and v > 0):
                raise InputError(f"{name}: got {v!r}, expected a positive number")
        for name in ("motion_weight", "discovery_weight", "coverage_mm", "border_px", "occluded_edge_sigma"):
            v = getattr(self, name)
            if not (is_real(v) and math.isfinite(v) and v >= 0):
                raise InputError(f"{name}: got {v!r}, expected a finite number >= 0")
        for name in ("p_occluder", "p_occluder_seen", "min_visible_fraction"):
            v = getattr(self, name)
            if not (is_real(v) and 0 <= v < 1):
                raise InputError(f"{name}: got {v!r}, expected a probability in [0, 1)")
        if (
            self.box_noise is not None
            and self.box_noise != "auto"
            and not (is_real(self.box_noise) and math.isfinite(self.box_noise) and self.box_noise >= 0)
        ):
            raise InputError(f"box_noise: got {self.box_noise!r}, expected a fraction >= 0 or 'auto'")
        if not (is_real(self.min_box_noise) and 0 <= self.min_box_noise < 1):
            raise InputError(f"min_box_noise: got {self.min_box_noise!r}, expected a fraction in [0, 1)")
        if not (is_real(self.reach_m) and self.reach_m > 0):
            raise InputError(f"reach_m: got {self.reach_m!r}, expected a positive number of metres")
        if not isinstance(self.joint_confidence, bool):
            raise InputError(f"joint_confidence: got {self.joint_confidence!r}, expected true or false")
        if not is_int(self.coverage_points) or self.coverage_points < 2:
            raise InputError(f"coverage_points: got {self.coverage_points!r}, expected an integer >= 2")
        b = np.asarray(self.base_centre, dtype=float)
        if b.shape != (3,) or not np.all(np.isfinite(b)):
            raise InputError(f"base_centre: got {self.base_centre!r}, expected [x, y, z] metres")

    @property
    def stated_sensor(self) -> SensorModel:
        """The sensor model with the stated box noise as its ``alpha``."""
        if self.box_noise is None or self.box_noise == "auto":  # "auto" is resolved per plan (plan_from_state)
            return self.sensor
        return replace(self.sensor, alpha=float(self.box_noise))
