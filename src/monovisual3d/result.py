"""Localisation results: the objects found and how they were found."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Keys :meth:`DetectedObject.to_dict` writes itself; ``extra`` may not use them.
STANDARD_KEYS = frozenset(
    {"position", "score", "radius", "covariance", "associations", "n_cells", "shape", "semi_axes", "quaternion_xyzw", "volume_m3"}
)
#: Object shapes a result may name.
OBJECT_SHAPES = ("sphere", "spheroid", "ellipsoid")


@dataclass
class DetectedObject:
    """One localised object.

    Attributes
    ----------
    position : ndarray, shape (3,), metres, base frame
    score : float
        Method-specific confidence (paper: posterior mass of the cluster).
    radius : float or None, metres (methods that estimate size); for non-spheres the
        volume-equivalent radius ``(a b c)^(1/3)``, filled in from ``semi_axes`` when not given
    covariance : ndarray, shape (3, 3), m^2, base frame, or None
    associations : dict view index -> detection index (methods that associate)
    n_cells : int or None, grid cells in the object's cluster
    extra : dict, method-specific fields written to JSON; they may not use the keys of
        :data:`STANDARD_KEYS` (ValueError)
    shape : ``"sphere"``, ``"spheroid"``, ``"ellipsoid"`` or None, the model fitted
    semi_axes : ndarray, shape (3,), metres, or None; ``[a, b, c]`` along the columns of the rotation
        given by ``quaternion_xyzw``
    quaternion_xyzw : ndarray, shape (4,), or None, orientation of the axes in the base frame

    Examples
    --------
    >>> o = DetectedObject(np.zeros(3), 1.0, shape="spheroid", semi_axes=np.array([0.02, 0.02, 0.09]))
    >>> round(o.radius * 1e3, 1), round(o.volume_m3 * 1e6, 1)
    (33.0, 150.8)
    """

    position: NDArray[np.float64]
    score: float
    radius: float | None = None
    covariance: NDArray[np.float64] | None = None
    associations: dict[int, int] = field(default_factory=dict)
    n_cells: int | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    shape: str | None = None
    semi_axes: NDArray[np.float64] | None = None
    quaternion_xyzw: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        self.semi_axes, self.radius, self.quaternion_xyzw = normalised_shape(
            self.shape, self.semi_axes, self.radius, self.quaternion_xyzw
        )
        _check_extra(self.extra)

    @classmethod
    def from_ellipsoid(
        cls, centre_base: ArrayLike, semi_axes: ArrayLike, quaternion_xyzw: ArrayLike, score: float, shape: str, **fields: Any
    ) -> DetectedObject:
        """An object with a fitted ellipsoid; ``radius`` becomes the volume-equivalent radius (or ``a`` for a sphere)."""
        return cls(
            np.asarray(centre_base, dtype=float),
            score,
            shape=shape,
            semi_axes=np.asarray(semi_axes, dtype=float),
            quaternion_xyzw=np.asarray(quaternion_xyzw, dtype=float),
            **fields,
        )

    @property
    def volume_m3(self) -> float | None:
        """Volume (m^3): ``4/3 pi a b c`` from the semi-axes, else ``4/3 pi r^3``; None without a size."""
        if self.semi_axes is not None:
            return float(4.0 / 3.0 * np.pi * np.prod(self.semi_axes))
        if self.radius is not None:
            return float(4.0 / 3.0 * np.pi * self.radius**3)
        return None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"position": [float(x) for x in self.position], "score": float(self.score)}
        if self.radius is not None:
            out["radius"] = float(self.radius)
        if self.covariance is not None:
            out["covariance"] = np.asarray(self.covariance).tolist()
        if self.associations:
            out["associations"] = {str(k): int(v) for k, v in self.associations.items()}
        if self.n_cells is not None:
            out["n_cells"] = int(self.n_cells)
        if self.shape is not None:
            out["shape"] = self.shape
        if self.semi_axes is not None:
            out["semi_axes"] = [float(x) for x in self.semi_axes]
        if self.quaternion_xyzw is not None:
            out["quaternion_xyzw"] = [float(x) for x in self.quaternion_xyzw]
        if self.volume_m3 is not None:
            out["volume_m3"] = self.volume_m3
        _check_extra(self.extra)
        out.update(self.extra)
        return out


def normalised_shape(
    shape: str | None, semi_axes: ArrayLike | None, radius: float | None, quaternion_xyzw: ArrayLike | None
) -> tuple[NDArray[np.float64] | None, float | None, NDArray[np.float64] | None]:
    """An object's shape fields checked and normalised: ``semi_axes`` as floats (3,), ``radius`` the volume-equivalent
    radius ``(a b c)^(1/3)`` when not given, ``quaternion_xyzw`` of unit norm (ValueError naming the field when one is
    not what it should be)."""
    if shape is not None and shape not in OBJECT_SHAPES:
        raise ValueError(f"shape: got {shape!r}, expected one of {list(OBJECT_SHAPES)}")
    s = q = None
    if semi_axes is not None:
        s = np.asarray(semi_axes, dtype=float)
        if s.shape != (3,) or not np.all(np.isfinite(s)) or not np.all(s > 0):
            raise ValueError(f"semi_axes: got {semi_axes!r}, expected three positive lengths in metres")
        if radius is None:
            radius = float(np.cbrt(np.prod(s)))
    if quaternion_xyzw is not None:
        q = np.asarray(quaternion_xyzw, dtype=float)
        n = float(np.linalg.norm(q)) if q.shape == (4,) else 0.0
        if not abs(n - 1.0) < 1e-3:
            raise ValueError(f"quaternion_xyzw: got {quaternion_xyzw!r}, expected a unit quaternion (x, y, z, w)")
        q = q / n
    return s, radius, q


def _check_extra(extra: dict[str, Any]) -> None:
    clash = sorted(STANDARD_KEYS.intersection(extra))
    if clash:
        raise ValueError(f"extra: key {clash[0]!r} would shadow the standard field of the same name; use another name")


@dataclass
class Result:
    """Output of :func:`monovisual3d.localize`.

    Attributes
    ----------
    objects : list of DetectedObject
    method : str
    grid : dict, description of the grid used
    timing_s : dict, seconds per stage
    config : dict, the options used (plain JSON values)
    warnings : list of str
    diagnostics : dict, method-specific statistics (e.g. the bayes search's hypothesis counts, the sparse
        engine's active set)
    pose_corrections : list of dict, per view: the estimated correction of its reported pose (``bayes`` with a
        stated pose uncertainty; empty otherwise), see :func:`monovisual3d.methods.bayes.poses.bundle`
    quality : dict, what the result says of its own trustworthiness (empty: the method has no quality model):
        ``verdict`` (``ok``, ``suspect``, ``unreliable``), ``causes`` (list of :meth:`monovisual3d.verdict.Cause.to_dict`),
        and the method's consistency figures (e.g. per object ``residual_chi2`` and ``dof``, per view ``consistency``)
    """

    objects: list[DetectedObject]
    method: str
    grid: dict[str, Any] = field(default_factory=dict)
    timing_s: dict[str, float] = field(default_factory=dict)
    config: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    diagnostics: dict[str, Any] = field(default_factory=dict)
    pose_corrections: list[dict[str, Any]] = field(default_factory=list)
    quality: dict[str, Any] = field(default_factory=dict)

    @property
    def positions(self) -> NDArray[np.float64]:
        """All positions, shape (M, 3), metres, base frame."""
        if not self.objects:
            return np.zeros((0, 3))
        return np.stack([o.position for o in self.objects])

    def to_dict(self) -> dict[str, Any]:
        return {
            "objects": [o.to_dict() for o in self.objects],
            "method": self.method,
            "config": self.config,
            "grid": self.grid,
            "timing_s": {k: float(v) for k, v in self.timing_s.items()},
            "warnings": list(self.warnings),
            "diagnostics": dict(self.diagnostics),
            "pose_corrections": list(self.pose_corrections),
            "quality": dict(self.quality),
        }

    def to_json(self, path: str | Path | None = None, indent: int = 2) -> str:
        """JSON text of the result (the CLI's output); also written to ``path`` when given."""
        text = json.dumps(self.to_dict(), indent=indent)
        if path is not None:
            Path(path).write_text(text + "\n")
        return text
