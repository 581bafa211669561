"""Generative box likelihood over sphere position and radius.

A hypothesis is a sphere (centre ``c``, radius ``r``). In a view it predicts
the box of its silhouette (:func:`predict_sphere_boxes`). An observed box is scored
against the prediction edge by edge, in units of an edge noise
``sigma = alpha * predicted size + sigma0``:

``l(e) = max(-e^2 / 2, -floor)``

where ``e`` is the signed normalised edge residual, positive when the
observed edge lies INSIDE the predicted box (what occlusion does) and
negative when outside, and ``floor`` is ``inward_floor`` or ``outward_floor``. The floors make the likelihood heavy-tailed: an
occluded edge costs at most ``inward_floor`` nats, a box edge that pokes out
of the predicted silhouette at most ``outward_floor``. An observed edge on the
image border is censored: it only says that the predicted edge is at or
beyond the border, so only outward residuals count there.

A box that misses the predicted box widened by ``gate_sigmas`` sigmas cannot be the object's
(:func:`.sensor.outside_gate`): it scores ``-inf``.

Per view, a hypothesis takes the best-matching box (max over boxes of
``match_bonus + sum of edge terms``) or, if none matches better, the miss
term ``log(p_miss)``; a view in which the sphere is not predicted in the image
(out of the field of view, or not entirely in front of the camera) carries no
information and contributes 0. Scores are log-likelihood ratios (nats)
against "no object here" and add across views.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from .sensor import SensorModel, box_edge_sigma_px, censored_edges, inward_edge_offsets, outside_gate

__all__ = ["box_scores", "edge_loglik", "edge_residuals", "pose_sigma_px", "view_scores"]


def pose_sigma_px(
    camera: Camera, depth: NDArray[np.floating] | float, position_sigma: float, rotation_sigma: float
) -> NDArray[np.float64]:
    """Camera-pose uncertainty projected into the image: the edge noise it adds, pixels.

    A position error of ``position_sigma`` (metres, per axis) shifts the image
    of a point at ``depth`` by about ``f * position_sigma / depth`` pixels; a
    rotation error of ``rotation_sigma`` (radians, per axis) shifts it by about
    ``f * rotation_sigma``. The two add in quadrature. Adding the result to the
    edge noise (in quadrature, ``extra_sigma_px`` of :func:`edge_residuals`)
    keeps hypotheses from being rejected for box offsets that imperfect arm
    kinematics or hand-eye calibration explain.

    Parameters
    ----------
    camera : Camera, ``f = max(fx, fy)``
    depth : float or ndarray, metres, optical z of the sphere centre (clamped at 1 mm)
    position_sigma : float, metres
    rotation_sigma : float, radians

    Returns
    -------
    sigma_px : ndarray, shape of ``depth``, pixels

    Examples
    --------
    >>> from monovisual3d.camera import Camera
    >>> cam = Camera.from_hfov(640, 480, 69.0)
    >>> round(float(pose_sigma_px(cam, 0.5, 0.0, 0.01)), 2)  # 10 mrad: f * 0.01 pixels at any depth
    4.66
    """
    f = max(camera.fx, camera.fy)
    z = np.maximum(np.asarray(depth, dtype=float), 1e-3)
    return f * np.sqrt((position_sigma / z) ** 2 + rotation_sigma**2)


def edge_residuals(
    pred: NDArray[np.floating],
    obs: NDArray[np.floating],
    model: SensorModel,
    width: int,
    height: int,
    extra_sigma_px: NDArray[np.floating] | float = 0.0,
) -> NDArray[np.float64]:
    """Signed normalised edge residuals, shape (..., 4): positive = observed edge inside the prediction.

    Parameters
    ----------
    pred : ndarray, shape (..., 4), predicted boxes (unclipped), pixels
    obs : ndarray, shape (4,), one observed box, or shape (..., 4) broadcastable to ``pred``, pixels
    extra_sigma_px : ndarray broadcastable to pred.shape[:-1], or float
        Extra edge noise added in quadrature, e.g. the projected size of a grid
        cell when the hypothesis stands for a whole cell rather than a point.
    """
    obs = np.asarray(obs, dtype=float)
    return _censored_offsets(pred, obs, model, width, height) / box_edge_sigma_px(model, pred, extra_sigma_px)


def _censored_offsets(
    pred: NDArray[np.floating], obs: NDArray[np.floating], model: SensorModel, width: int, height: int
) -> NDArray[np.float64]:
    """:func:`.sensor.inward_edge_offsets`, pixels, with the edges on the image border clipped to <= 0 (only outward
    residuals count there)."""
    d = inward_edge_offsets(pred, obs)
    censored = censored_edges(obs, width, height, model.border_px)
    return np.where(censored, np.minimum(d, 0.0), d) if censored.any() else d


def edge_loglik(e: NDArray[np.floating], model: SensorModel) -> NDArray[np.float64]:
    """Robust per-edge log-likelihood: ``max(-e^2/2, -floor)``, 0 at a perfect match.

    ``floor`` is ``inward_floor`` for ``e > 0`` (observed edge inside the
    prediction) and ``outward_floor`` otherwise. NaN (no prediction) scores
    the outward floor.
    """
    floor = np.where(e > 0, model.inward_floor, model.outward_floor)
    out = np.maximum(-0.5 * e * e, -floor)
    return np.where(np.isnan(e), -model.outward_floor, out)


def box_scores(
    pred: NDArray[np.floating],
    obs: NDArray[np.floating],
    model: SensorModel,
    width: int,
    height: int,
    extra_sigma_px: NDArray[np.floating] | float = 0.0,
    gate_px: NDArray[np.floating] | None = None,
) -> NDArray[np.float64]:
    """``match_bonus + sum of edge log-likelihoods`` of one observed box, shape pred.shape[:-1]; ``-inf`` where the
    box lies outside the gate (:func:`.sensor.outside_gate`), the prediction widened by ``gate_px`` (..., 4) pixels
    (default: ``gate_sigmas`` sigmas of the edge noise with ``extra_sigma_px``, :func:`.sensor.gate_widening_px`)."""
    obs = np.asarray(obs, dtype=float)
    sigma = box_edge_sigma_px(model, pred, extra_sigma_px)
    d = _censored_offsets(pred, obs, model, width, height)
    score = model.match_bonus + edge_loglik(d / sigma, model).sum(axis=-1)
    widening = model.gate_sigmas * sigma if gate_px is None else gate_px
    return np.where(outside_gate(pred, d, widening), -np.inf, score)


def view_scores(
    pred: NDArray[np.floating],
    visible: NDArray[np.bool_],
    boxes_xyxy: NDArray[np.floating],
    available: NDArray[np.bool_],
    model: SensorModel,
    width: int,
    height: int,
    extra_sigma_px: NDArray[np.floating] | float = 0.0,
    gate_px: NDArray[np.floating] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Per-view log-likelihood ratio of every hypothesis and its associated box.

    Parameters
    ----------
    pred : ndarray, shape (..., 4), predicted boxes
    visible : ndarray, shape (...), bool
    boxes_xyxy : ndarray, shape (B, 4), the view's observed boxes
    available : ndarray, shape (B,), bool: boxes not yet explained by an extracted object
    model : SensorModel
    extra_sigma_px : see :func:`edge_residuals`
    gate_px : ndarray, shape (..., 4), optional, see :func:`box_scores`

    Returns
    -------
    llr : ndarray, shape (...), nats: ``max(log p_miss, best box score)`` where visible, else 0
    assoc : ndarray, shape (...), index of the associated box, -1 for a miss or not visible
    """
    best = np.full(visible.shape, model.miss_term)
    assoc = np.full(visible.shape, -1, dtype=np.intp)
    for j in np.flatnonzero(available):
        s = box_scores(pred, boxes_xyxy[j], model, width, height, extra_sigma_px, gate_px)
        better = s > best
        best = np.where(better, s, best)
        assoc = np.where(better, j, assoc)
    best = np.where(visible, best, 0.0)
    assoc = np.where(visible, assoc, -1)
    return best, assoc
