"""Options of the ``bayes`` method (:class:`BayesConfig`)."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...errors import InputError
from ...grid import DEFAULT_REACH_M
from ..options import DEFAULT_MAX_MEMORY, check_threads, is_real, parse_bytes
from .likelihood import SensorModel

#: Compute backends of the ``bayes`` method: the fused numba kernels (default) and the numpy reference.
BACKENDS = ("numba", "numpy")


@dataclass(frozen=True)
class BayesConfig:
    """Options of the ``bayes`` method.

    Attributes
    ----------
    resolution : float, metres, cell size of the scored grid (accuracy comes from the continuous refinement;
        0.02 is ~15% faster but lost fruit under occlusion with noisy boxes in the accuracy benchmark)
    coarse_resolution : float, metres, cell size of the first search level (``resolution`` if that is coarser;
        coarser still when the workspace would not fit in ``max_memory``)
    radius_min : float, metres, smallest object radius
    radius_max : float, metres, largest object radius
    n_radii : int, log-spaced radius bins between radius_min and radius_max
    reach : float, metres, manipulator reach R (a cube of side 2R in front of the first view) when the session has no workspace
    accept : float, nats, minimum refined score of a reported object; raise it (e.g. 12) when the detector gives
        false positives, at the cost of missing occluded fruit
    min_views : int, minimum number of views with an associated box
    use_masks : bool, use instance masks in the refinement when detections carry them
    alpha : float, sensor model: edge noise as a fraction of the box size
    sigma0_px : float, sensor model: edge noise floor, pixels
    inward_floor : float, sensor model: log-likelihood floor of an edge inside the predicted box (occlusion)
    outward_floor : float, sensor model: log-likelihood floor of an edge outside the predicted box
    match_bonus : float, sensor model: nats per matched box
    p_miss : float, sensor model: probability that a visible object has no box
    border_px : float, sensor model: box edges this close to the image border are censored (truncated)
    prune_slack : float, nats: at each search level, cells whose best score is below ``accept - prune_slack`` are dropped
    lookahead : int, at each extraction step refine up to this many distinct candidates near the best grid score and
        keep the best refined one (1 = plain greedy); the steal pass also tries this many
    lookahead_margin : float, nats: candidates of the look-ahead score within this of the best
    max_hypotheses : int, cap on the (cell, radius) hypotheses scored at one search level (the memory budget may lower it;
        the best-scoring cells are kept)
    radius_margin_bins : int, radius bins a child cell inherits on each side of those its parent kept
    swap : bool, after extraction, swap the boxes of overlapping objects in a view when that fits both better
    steal : bool, after extraction, give a fruit back the box a neighbour took when the neighbour can do without it
    pose_sigma_mm : float, millimetres, stated 1-sigma error of each view's camera position per axis (0: exact)
    pose_sigma_deg : float, degrees, stated 1-sigma error of each view's camera rotation per axis (0: exact)
    backend : str, numba (fused compiled kernels) or numpy (the readable reference)
    threads : int or None, CPU threads of the compiled kernels (None: chosen by the amount of work)
    max_memory : int or str, bytes (or text such as 2GiB): memory budget of the call
    """

    resolution: float = 0.01
    coarse_resolution: float = 0.04
    radius_min: float = 0.01
    radius_max: float = 0.08
    n_radii: int = 16
    reach: float = DEFAULT_REACH_M
    accept: float = 8.0
    min_views: int = 2
    use_masks: bool = True
    # the sensor model's fields, flat here so they are options of the method; defaults from SensorModel
    alpha: float = SensorModel.alpha
    sigma0_px: float = SensorModel.sigma0_px
    inward_floor: float = SensorModel.inward_floor
    outward_floor: float = SensorModel.outward_floor
    match_bonus: float = SensorModel.match_bonus
    p_miss: float = SensorModel.p_miss
    border_px: float = SensorModel.border_px
    prune_slack: float = 2.0
    lookahead: int = 3
    lookahead_margin: float = 4.0
    max_hypotheses: int = 8_000_000
    radius_margin_bins: int = 1
    swap: bool = True
    steal: bool = True
    pose_sigma_mm: float = 0.0
    pose_sigma_deg: float = 0.0
    backend: str = "numba"
    threads: int | None = None
    max_memory: int | str = DEFAULT_MAX_MEMORY

    def __post_init__(self) -> None:
        for name in ("n_radii", "lookahead", "min_views", "max_hypotheses"):
            v = getattr(self, name)
            if not (is_real(v) and float(v).is_integer() and v >= 1):
                raise InputError(f"{name}: got {v!r}, expected an integer >= 1")
            object.__setattr__(self, name, int(v))
        v = self.radius_margin_bins
        if not (is_real(v) and float(v).is_integer() and v >= 0):
            raise InputError(f"radius_margin_bins: got {v!r}, expected an integer >= 0")
        object.__setattr__(self, "radius_margin_bins", int(v))
        for name in ("radius_min", "radius_max", "resolution", "coarse_resolution", "reach"):
            v = getattr(self, name)
            if not (is_real(v) and np.isfinite(v) and v > 0):
                raise InputError(f"{name}: got {v!r}, expected a positive number of metres")
        if not self.radius_min < self.radius_max:
            raise InputError(f"radius_min/radius_max: got {self.radius_min}/{self.radius_max}, expected 0 < min < max (metres)")
        for name in ("pose_sigma_mm", "pose_sigma_deg", "prune_slack", "lookahead_margin"):
            v = getattr(self, name)
            if not (is_real(v) and np.isfinite(v) and v >= 0):
                raise InputError(f"{name}: got {v!r}, expected a finite number >= 0")
        if not (is_real(self.accept) and np.isfinite(self.accept)):
            raise InputError(f"accept: got {self.accept!r}, expected a finite number of nats")
        if self.min_views < 2:
            raise InputError(f"min_views: got {self.min_views}, expected >= 2 (one view cannot fix depth)")
        for name in ("use_masks", "swap", "steal"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise InputError(f"{name}: got {getattr(self, name)!r}, expected true or false")
        if self.backend not in BACKENDS:
            raise InputError(f"backend: got {self.backend!r}, expected one of {list(BACKENDS)} for method 'bayes'")
        object.__setattr__(self, "threads", check_threads(self.threads))
        object.__setattr__(self, "max_memory", parse_bytes(self.max_memory))
        self.sensor  # validates the sensor fields  # noqa: B018

    @property
    def search_start(self) -> float:
        """Cell size of the first search level, metres: ``coarse_resolution``, or ``resolution`` if that is coarser."""
        return float(max(self.coarse_resolution, self.resolution))

    @property
    def sensor(self) -> SensorModel:
        """The sensor-model fields of this config as a :class:`SensorModel`."""
        return SensorModel(**{f.name: getattr(self, f.name) for f in fields(SensorModel)})

    @property
    def pose_position_sigma(self) -> float:
        """Stated camera position uncertainty, metres per axis."""
        return float(self.pose_sigma_mm) / 1000.0

    @property
    def pose_rotation_sigma(self) -> float:
        """Stated camera rotation uncertainty, radians per axis."""
        return float(np.radians(self.pose_sigma_deg))

    @property
    def poses_uncertain(self) -> bool:
        return self.pose_sigma_mm > 0 or self.pose_sigma_deg > 0

    @property
    def radii(self) -> NDArray[np.float64]:
        """Radius bins, shape (n_radii,), metres."""
        if self.n_radii == 1:
            return np.array([np.sqrt(self.radius_min * self.radius_max)])
        return np.geomspace(self.radius_min, self.radius_max, self.n_radii)

    def to_dict(self) -> dict[str, Any]:
        """The options as plain JSON values."""
        return {f.name: getattr(self, f.name) for f in fields(self)}
