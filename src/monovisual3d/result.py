"""Localisation results: the objects found and how they were found."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray


@dataclass
class DetectedObject:
    """One localised object.

    Attributes
    ----------
    position : ndarray, shape (3,), metres, base frame
    score : float
        Method-specific confidence (paper: posterior mass of the cluster).
    radius : float or None, metres (methods that estimate size)
    covariance : ndarray, shape (3, 3), m^2, base frame, or None
    associations : dict view index -> detection index (methods that associate)
    n_cells : int or None, grid cells in the object's cluster
    """

    position: NDArray[np.float64]
    score: float
    radius: float | None = None
    covariance: NDArray[np.float64] | None = None
    associations: dict[int, int] = field(default_factory=dict)
    n_cells: int | None = None
    extra: dict[str, Any] = field(default_factory=dict)

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
        out.update(self.extra)
        return out


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
        stated pose uncertainty; empty otherwise), see :func:`monovisual3d.methods.bayes.pipeline.bundle`
    """

    objects: list[DetectedObject]
    method: str
    grid: dict[str, Any] = field(default_factory=dict)
    timing_s: dict[str, float] = field(default_factory=dict)
    config: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    diagnostics: dict[str, Any] = field(default_factory=dict)
    pose_corrections: list[dict[str, Any]] = field(default_factory=list)

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
        }

    def to_json(self, path: str | Path | None = None, indent: int = 2) -> str:
        """JSON text of the result (the CLI's output); also written to ``path`` when given."""
        text = json.dumps(self.to_dict(), indent=indent)
        if path is not None:
            Path(path).write_text(text + "\n")
        return text
