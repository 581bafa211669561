"""The ``bayes`` sensor model: box-edge noise and edge residuals, the one home of both.

:class:`SensorModel` holds the parameters; :func:`box_edge_sigma_px` (edge noise ``alpha * size + sigma0_px``),
:func:`inward_edge_offsets` (signed edge residual, positive inward) and :func:`censored_edges` (edges on the
image border) are used by the likelihood, the refinement, the mask residuals and the next-view planner.
The module imports no numpy at load time (the functions import it when called), so options load fast.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ...errors import InputError

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from ...camera import Camera

#: The normalised residual that stands in for an edge the model cannot predict (the object behind the camera, or the
#: camera inside it): far beyond any robust loss's outlier scale, so the solver steps back.
UNDEFINED_RESIDUAL = 1e3


@dataclass(frozen=True)
class SensorModel:
    """Parameters of the box likelihood (see the module docstring).

    Attributes
    ----------
    alpha : float, edge noise as a fraction of the predicted box size (raised per session where the boxes scatter well
        beyond it, unless ``edge_noise='stated'``: :mod:`.edge_noise`)
    sigma0_px : float, edge noise floor in pixels (quantisation)
    inward_floor : float, nats: the most an edge inside the prediction (occlusion) can cost
    outward_floor : float, nats: the most an edge outside the prediction can cost
    match_bonus : float, nats: log-ratio of a perfectly matching box vs. no object
    p_miss : float, probability that a visible object yields no box (missed or hidden)
    border_px : float, an observed edge within this distance of the image border is censored
    gate_sigmas : float, a box can be an object's box only if it meets the object's predicted box widened by
        this many edge-noise sigmas on every side (:func:`outside_gate`)
    """

    alpha: float = 0.05
    sigma0_px: float = 1.0
    inward_floor: float = 3.0
    outward_floor: float = 6.0
    match_bonus: float = 8.0
    p_miss: float = 0.1
    border_px: float = 1.0
    gate_sigmas: float = 3.0

    def __post_init__(self) -> None:
        if not 0 < self.p_miss < 1:
            raise InputError(f"p_miss: got {self.p_miss}, expected a probability in (0, 1)")
        if not self.gate_sigmas >= 0:
            raise InputError(f"gate_sigmas: got {self.gate_sigmas}, expected a number of sigmas >= 0")
        if self.alpha < 0 or self.sigma0_px <= 0:
            raise InputError("alpha must be >= 0 and sigma0_px > 0")

    @property
    def miss_term(self) -> float:
        return math.log(self.p_miss)

    def edge_sigma_px(self, size_px: Any) -> Any:
        """Edge noise of a box edge, pixels: ``alpha * size_px + sigma0_px``.

        ``size_px`` (float or ndarray, pixels) is the predicted box's extent along the edge's
        axis: its width for the left and right edges, its height for the top and bottom ones.

        Examples
        --------
        >>> SensorModel(alpha=0.05, sigma0_px=1.0).edge_sigma_px(100.0)
        6.0
        """
        return self.alpha * size_px + self.sigma0_px


def box_edge_sigma_px(model: SensorModel, boxes: NDArray[np.floating], extra_sigma_px: Any = 0.0) -> NDArray[np.float64]:
    """Edge noise of predicted boxes, per edge, pixels (the one place the box-edge noise is written).

    Parameters
    ----------
    model : SensorModel
    boxes : ndarray, shape (..., 4), predicted ``bbox_xyxy``, pixels
    extra_sigma_px : float or ndarray broadcastable to ``boxes.shape[:-1]``, pixels
        Extra noise added in quadrature (pose uncertainty, the size of a grid cell); 0: none.

    Returns
    -------
    sigma_px : ndarray, shape (..., 4), ``(sx, sy, sx, sy)`` with ``sx = alpha * width + sigma0_px``
    """
    import numpy as np

    sx = model.edge_sigma_px(boxes[..., 2] - boxes[..., 0])
    sy = model.edge_sigma_px(boxes[..., 3] - boxes[..., 1])
    if np.any(extra_sigma_px):
        sx = np.sqrt(sx * sx + extra_sigma_px * extra_sigma_px)
        sy = np.sqrt(sy * sy + extra_sigma_px * extra_sigma_px)
    return np.stack([sx, sy, sx, sy], axis=-1)


def inward_edge_offsets(pred: NDArray[np.floating], obs: NDArray[np.floating]) -> NDArray[np.float64]:
    """How far each observed edge lies inside the predicted box, pixels, shape (..., 4).

    Positive where the observed edge is inside the prediction (what occlusion does), negative where it is
    outside: ``(x1_obs - x1_pred, y1_obs - y1_pred, x2_pred - x2_obs, y2_pred - y2_obs)``.

    Parameters
    ----------
    pred : ndarray, shape (..., 4), predicted ``bbox_xyxy``, pixels
    obs : ndarray, shape (..., 4), observed ``bbox_xyxy`` broadcastable to ``pred``, pixels
    """
    import numpy as np

    return np.stack(
        [obs[..., 0] - pred[..., 0], obs[..., 1] - pred[..., 1], pred[..., 2] - obs[..., 2], pred[..., 3] - obs[..., 3]],
        axis=-1,
    )


def outside_gate(
    pred: NDArray[np.floating], inward_px: NDArray[np.floating], widening_px: NDArray[np.floating]
) -> NDArray[np.bool_]:
    """Whether an observed box misses the predicted box widened by ``widening_px`` on every side, shape (...).

    In residuals: an observed edge lies further inside the prediction than the prediction's own extent plus the
    widening, i.e. the observed box lies wholly beyond the opposite predicted edge. Occlusion only shrinks a box
    inside its object's silhouette and noise moves its edges by a few sigmas, so such a box is not this object's
    (a box beside the prediction would otherwise still pay only the two edge floors).

    Parameters
    ----------
    pred : ndarray, shape (..., 4), predicted ``bbox_xyxy``, pixels
    inward_px : ndarray, shape (..., 4), :func:`inward_edge_offsets` (censored edges already clipped to <= 0), pixels
    widening_px : ndarray, shape (..., 4), :func:`gate_widening_px`, pixels
    """
    import numpy as np

    extent = np.stack([pred[..., 2] - pred[..., 0], pred[..., 3] - pred[..., 1]] * 2, axis=-1)
    return np.any(inward_px > extent + widening_px, axis=-1)


def cell_shift_px(
    camera: Camera, pred: NDArray[np.floating], depth: NDArray[np.floating] | float, half_diagonal: float
) -> NDArray[np.float64]:
    """The most a point's moving anywhere inside a grid cell moves the edges of its predicted box, pixels, shape (..., 4).

    A move ``d`` (``|d| <= h``, the cell's half-diagonal) of a point at depth ``Z`` moves an edge at normalised image
    coordinate ``e`` by ``f (d_x - e d_z) / (Z + d_z)``, at most ``f h sqrt(1 + e^2) / (Z - h)`` (``f = max(fx, fy)``;
    ``e`` the edge of the box further from the principal point on that axis), times the lens distortion's largest
    stretch (:meth:`.Camera.distortion_gain`). Infinite when the cell reaches the camera plane, 0 for a point
    (``h = 0``). ``tests/methods/bayes/test_sensor.py`` checks it against moved boxes.

    Parameters
    ----------
    camera : Camera
    pred : ndarray, shape (..., 4), predicted ``bbox_xyxy``, pixels
    depth : ndarray broadcastable to ``pred.shape[:-1]``, or float, metres: the cell centre's optical z
    half_diagonal : float, metres
    """
    import numpy as np

    if half_diagonal == 0:
        return np.zeros(np.shape(pred))
    ex = np.maximum(np.abs(pred[..., 0] - camera.cx), np.abs(pred[..., 2] - camera.cx)) / camera.fx
    ey = np.maximum(np.abs(pred[..., 1] - camera.cy), np.abs(pred[..., 3] - camera.cy)) / camera.fy
    near = np.asarray(depth, dtype=float) - half_diagonal
    with np.errstate(divide="ignore"):
        f = max(camera.fx, camera.fy) * camera.distortion_gain()
        scale = np.where(near > 1e-6, f * half_diagonal / np.maximum(near, 1e-6), np.inf)
    sx, sy = scale * np.sqrt(1 + ex * ex), scale * np.sqrt(1 + ey * ey)
    return np.stack([sx, sy, sx, sy], axis=-1)


def gate_widening_px(
    model: SensorModel, pred: NDArray[np.floating], noise_px: Any = 0.0, shift_px: Any = 0.0
) -> NDArray[np.float64]:
    """How far the gate reaches beyond each predicted edge, pixels, shape (..., 4): ``gate_sigmas`` edge-noise sigmas
    (:func:`box_edge_sigma_px` with the extra noise ``noise_px``) plus the bounded shift ``shift_px`` (..., 4) of a
    grid cell (:func:`cell_shift_px`; 0 for a point)."""
    return model.gate_sigmas * box_edge_sigma_px(model, pred, noise_px) + shift_px


def censored_edges(obs: NDArray[np.floating], width: int, height: int, border_px: float) -> NDArray[np.bool_]:
    """True for each observed edge on the image border (within ``border_px``), shape (..., 4).

    Such an edge only says that the object reaches at least that far: only outward residuals count there.
    """
    import numpy as np

    return np.stack(
        [obs[..., 0] <= border_px, obs[..., 1] <= border_px, obs[..., 2] >= width - border_px, obs[..., 3] >= height - border_px],
        axis=-1,
    )
