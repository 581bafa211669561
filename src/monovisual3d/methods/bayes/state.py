"""What the ``bayes`` passes hand each other: the objects found so far and what the passes learn about them.

:class:`Found` is one object as the passes carry it (the result's fields and typed fields of its own, never a dict of
extras); :class:`State` is everything one pass hands the next (:data:`.pipeline.PASSES`), frozen: a pass returns a new
state. :class:`Hypotheses` is what the search leaves for the extraction and the association repairs.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...result import DetectedObject, normalised_shape
from ...verdict import Cause

#: Boxes explained by accepted objects: ``(v, j)`` pairs, ``v`` indexing ``Problem.views``, ``j`` a detection there.
Taken = frozenset[tuple[int, int]]

#: The scores of hypotheses: total (N, K) nats, -inf where not scored; views with an associated box (N, K);
#: associated box per view (V, N, K), -1 for none.
Scores = tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.int16]]


@dataclass(frozen=True)
class Found:
    """One object as the passes carry it.

    Attributes
    ----------
    position : ndarray, shape (3,), metres, base frame
    score : float, nats: the evidence for it (log-likelihood ratio of its boxes against none)
    radius : float or None, metres: the search's sphere (a spheroid's semi-axis across its axis); for a fitted shape
        the volume-equivalent radius, filled in from ``semi_axes`` when not given
    covariance : ndarray, shape (3, 3), m^2, base frame, or None (undetermined)
    associations : dict, session view index -> detection index: the boxes it holds
    n_cells : int or None
    shape, semi_axes, quaternion_xyzw : the fitted model (``sphere``, ``spheroid``, ``ellipsoid``), its semi-axes (3,),
        metres, and orientation (4,) (x, y, z, w); None before the shape pass
    semi_up : float or None, metres: a spheroid of the search, its semi-axis along its axis (None: a sphere)
    axis : ndarray, shape (3,), unit, base frame, or None: a lying spheroid's long axis (None: ``up``)
    solid : str or None: ``cylinder`` or ``cuboid`` when the shape pass kept a solid (``semi_axes`` its radius or
        half-sides)
    radius_std : float or None, metres: the radius's posterior std
    n_views : int or None: views it was refined on
    shape_bic, shape_rms_px : float or None: the shape fit's BIC and RMS edge residual (pixels)
    pose_corrected : bool: refined jointly with a pose correction per view (:mod:`.poses`)
    """

    position: NDArray[np.float64]
    score: float
    radius: float | None = None
    covariance: NDArray[np.float64] | None = None
    associations: dict[int, int] = field(default_factory=dict)
    n_cells: int | None = None
    shape: str | None = None
    semi_axes: NDArray[np.float64] | None = None
    quaternion_xyzw: NDArray[np.float64] | None = None
    semi_up: float | None = None
    axis: NDArray[np.float64] | None = None
    solid: str | None = None
    radius_std: float | None = None
    n_views: int | None = None
    shape_bic: float | None = None
    shape_rms_px: float | None = None
    pose_corrected: bool = False

    def __post_init__(self) -> None:
        semi_axes, radius, quaternion = normalised_shape(self.shape, self.semi_axes, self.radius, self.quaternion_xyzw)
        object.__setattr__(self, "semi_axes", semi_axes)
        object.__setattr__(self, "radius", radius)
        object.__setattr__(self, "quaternion_xyzw", quaternion)

    def learned(self) -> dict[str, Any]:
        """What the passes learned about the object beyond its estimate (:data:`LEARNED`), by field name: what a new
        estimate of it (a refit, a new association) carries over."""
        return {name: getattr(self, name) for name in LEARNED}

    def as_result(self) -> DetectedObject:
        """The object as a result reports it: what the passes learned (:data:`LEARNED`) as the result's extra fields,
        those that are set."""
        extra: dict[str, Any] = {}
        for name, value in self.learned().items():
            if value is not None and value is not False:
                extra[name] = [float(x) for x in value] if name == "axis" else value
        return DetectedObject(
            self.position,
            self.score,
            self.radius,
            self.covariance,
            dict(self.associations),
            self.n_cells,
            extra,
            self.shape,
            self.semi_axes,
            self.quaternion_xyzw,
        )


#: The fields of :class:`Found` beyond the estimate and its shape: what the passes learn about an object.
LEARNED = ("semi_up", "axis", "solid", "radius_std", "n_views", "shape_bic", "shape_rms_px", "pose_corrected")


@dataclass(frozen=True)
class Hypotheses:
    """The last search level: hypotheses scored with every box available (or the level above it, with
    ``child_cell``: its cells' children are scored by the extraction).

    Attributes
    ----------
    centres_base : ndarray, shape (N, 3), metres, base frame: cell centres
    radii : ndarray, shape (K,), metres: the shape bins' semi-axis across ``up`` (a sphere's radius)
    cell : float, metres, cell size of the level
    scores : (total (N, K), n_assoc (N, K), assoc (V, N, K)), see :data:`Scores`
    mask : ndarray, shape (N, K), bool: the radius bins scored per cell
    n_scored : int, hypotheses the search scored over all levels (not the children the extraction scores)
    start_cell : float, metres, cell size of the first level
    capped : bool, whether a level had more hypotheses than the budget and kept only the best cells
    semi_up : ndarray, shape (K,), metres: the bins' semi-axis along their axis (equal to ``radii`` for spheres)
    axes : ndarray, shape (K, 3), unit, base frame: the bins' symmetry axis (``up``; horizontal for lying bins)
    child_cell : float, metres, or None: the last level's cell size when that level is left to the extraction
        (:func:`search`): the hypotheses are then the level above it, each cell's children to be scored when it
        nears the best
    children_base : ndarray, shape (8N, 3), metres, base frame, or None: the centres of each cell's 8 children
        (rows ``8 i`` to ``8 i + 7``: cell ``i``'s), with ``child_cell``
    children_mask : ndarray, shape (8N, K), bool, or None: the bins each child would score (its parent's, widened)
    """

    centres_base: NDArray[np.float64]
    radii: NDArray[np.float64]
    cell: float
    scores: Scores
    mask: NDArray[np.bool_]
    n_scored: int
    start_cell: float
    capped: bool
    semi_up: NDArray[np.float64] | None = None
    axes: NDArray[np.float64] | None = None
    child_cell: float | None = None
    children_base: NDArray[np.float64] | None = None
    children_mask: NDArray[np.bool_] | None = None

    def bin_semi_up(self, k: int) -> float | None:
        """Semi-axis along its axis of bin ``k`` (metres), None for a sphere bin."""
        if self.semi_up is None or self.semi_up[k] == self.radii[k]:
            return None
        return float(self.semi_up[k])

    def bin_axis(self, k: int) -> NDArray[np.float64] | None:
        """Symmetry axis (3,), base frame, of the spheroid bin ``k``; None for a sphere bin or without ``axes``."""
        if self.axes is None or self.bin_semi_up(k) is None:
            return None
        return self.axes[k]

    def stats(self) -> dict[str, float | int | bool]:
        """``cell_size`` (the last level's), ``n_scored`` (by the search), ``n_cells_kept`` (the search's cells: those of
        the level above the last where ``lazy_last_level``), ``start_cell_size``, ``capped``, ``lazy_last_level``."""
        return {
            "cell_size": self.cell if self.child_cell is None else self.child_cell,
            "n_scored": self.n_scored,
            "n_cells_kept": len(self.centres_base),
            "start_cell_size": self.start_cell,
            "capped": self.capped,
            "lazy_last_level": self.child_cell is not None,
        }


@dataclass(frozen=True)
class ObjectQuality:
    """One object's residuals under the sensor model.

    Attributes
    ----------
    residual_chi2 : float, sum of squared normalised edge residuals (sensor model)
    dof : int, edges used less the parameters fitted (may be <= 0: no redundancy)
    variance_factor : float, its variance factor after shrinkage toward the session's (1: the sensor model)
    covariance_reason : str or None, why its covariance is None (None: it has one)
    """

    residual_chi2: float
    dof: int
    variance_factor: float
    covariance_reason: str | None = None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "residual_chi2": self.residual_chi2,
            "dof": self.dof,
            "variance_factor": self.variance_factor,
        }
        if self.covariance_reason is not None:
            out["covariance_reason"] = self.covariance_reason
        return out


@dataclass(frozen=True)
class ViewQuality:
    """One view's residuals over the objects seen there.

    Attributes
    ----------
    view : int, the view's index in the session
    chi2 : float, sum of squared normalised edge residuals (sensor model)
    dof : float, the edges' share of the degrees of freedom (``1 - leverage`` each)
    consistency : float, ``chi2`` over what the session's noise predicts for it: 1 as the other views, above: worse
    p : float, probability of a ``chi2`` this large from the session's noise
    """

    view: int
    chi2: float
    dof: float
    consistency: float
    p: float

    def to_dict(self) -> dict[str, Any]:
        return {"view": self.view, "chi2": self.chi2, "dof": self.dof, "consistency": self.consistency, "p": self.p}


@dataclass(frozen=True)
class Quality:
    """The session's consistency under the sensor model (:mod:`.quality`).

    Attributes
    ----------
    objects : tuple of ObjectQuality, in the order of ``State.objects``
    views : tuple of ViewQuality, the views with an object's box
    variance_factor : float, the session's: robust chi-square over its degrees of freedom (1: the sensor model)
    centre_factor, size_factor : float, the variance factors of the boxes' centre and size parts
    robust_factor : float, the session's variance factor from the median absolute residual (corrected for the share of
        the degrees of freedom the fits take): what most edges say, a minority of boxes cut by leaves or taken from
        another fruit aside
    dof : int, the session's degrees of freedom
    unexplained_boxes : tuple of (view, box), session view index and detection index of each box that no object holds
        and none explains as its own box under the session's noise (:func:`.quality.unexplained_boxes`)
    n_boxes : int, boxes in all
    """

    objects: tuple[ObjectQuality, ...] = ()
    views: tuple[ViewQuality, ...] = ()
    variance_factor: float = 1.0
    centre_factor: float = 1.0
    size_factor: float = 1.0
    robust_factor: float = 1.0
    dof: int = 0
    unexplained_boxes: tuple[tuple[int, int], ...] = ()
    n_boxes: int = 0

    @property
    def unexplained(self) -> int:
        """How many boxes are unexplained."""
        return len(self.unexplained_boxes)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON values: what ``Result.quality`` holds besides the verdict and the causes."""
        return {
            "variance_factor": self.variance_factor,
            "centre_factor": self.centre_factor,
            "size_factor": self.size_factor,
            "robust_factor": self.robust_factor,
            "dof": self.dof,
            "objects": [o.to_dict() for o in self.objects],
            "views": [v.to_dict() for v in self.views],
            "n_boxes": self.n_boxes,
            "unexplained_boxes": [[v, j] for v, j in self.unexplained_boxes],
        }


@dataclass(frozen=True)
class State:
    """What one pass hands the next (:data:`.pipeline.PASSES`): a pass returns a new state, the old one unchanged.

    Attributes
    ----------
    objects : tuple of Found, the objects found so far
    hypotheses : Hypotheses or None, the search's (set by the search pass)
    pose_corrections : tuple of dict, per view with detections, its estimated pose correction (the poses pass, with a
        stated pose uncertainty; :func:`.poses.pose_corrections`)
    isolated_dropped : int, objects the isolated pass dropped
    view_shifts : tuple of dict, views whose boxes all sit off the same way (:func:`.view_shift.view_shifts`)
    causes : tuple of Cause, what the passes found wrong with the input (:class:`~monovisual3d.verdict.Cause`)
    quality : Quality or None, the objects' residuals under the sensor model (:mod:`.quality`, the last pass)
    """

    objects: tuple[Found, ...] = ()
    hypotheses: Hypotheses | None = None
    pose_corrections: tuple[dict[str, Any], ...] = ()
    isolated_dropped: int = 0
    view_shifts: tuple[dict[str, Any], ...] = ()
    causes: tuple[Cause, ...] = ()
    quality: Quality | None = None

    def with_objects(self, objects: Iterable[Found]) -> State:
        """This state with ``objects`` in place of its own."""
        return replace(self, objects=tuple(objects))
