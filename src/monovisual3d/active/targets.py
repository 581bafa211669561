"""What the planner reasons about: its state, the objects and tentative objects, their information so far.

A box no object explains (a fruit seen once, a fruit the others hide, a false positive) becomes a
tentative object on the box's ray at the depth a fruit of ``prior_radius_m`` would have. Every
target's information matrix is rebuilt from the views it was associated in (see
:mod:`monovisual3d.active.information`), leaving out the edges the observed box shows occluded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from ..errors import InputError
from ..methods.bayes.sensor import box_edge_sigma_px, inward_edge_offsets
from ..result import DetectedObject
from ..session import View, Workspace
from .config import PlannerConfig
from .information import border_weights, boxes_and_jacobians, fisher, occlusion_by_known, rms_mm


@dataclass(frozen=True)
class PlannerState:
    """What the planner knows: camera, views so far, estimated objects, workspace.

    Attributes
    ----------
    camera : Camera
    views : tuple of View
    objects : tuple of DetectedObject, the current estimate (position, radius, covariance, associations)
    workspace : Workspace or None
    """

    camera: Camera
    views: tuple[View, ...]
    objects: tuple[DetectedObject, ...]
    workspace: Workspace | None = None

    @property
    def unexplained(self) -> list[tuple[int, int]]:
        """(view index, detection index) of every box no object is associated with."""
        used = {(v, d) for o in self.objects for v, d in o.associations.items()}
        return [(v, d) for v, view in enumerate(self.views) for d in range(len(view.detections)) if (v, d) not in used]


#: Std of the weak position prior every target starts with, metres: it only keeps the information invertible.
POSITION_PRIOR_STD_M = 1.0
#: A view in which an object was predicted at least this visible (fraction of its disc not covered by nearer
#: fruit) but not detected counts as one in which something unknown hid it.
HIDDEN_IF_VISIBLE_FRACTION = 0.5
#: Smallest angular size (radians) taken for an unexplained box, so a degenerate box gives a finite depth.
MIN_BOX_ANGLE_RAD = 1e-4
#: Largest half-angle (radians) used for a tentative object's depth (a box filling the view: the fruit is close).
MAX_HALF_ANGLE_RAD = 1.0


@dataclass
class Targets:
    """Objects and tentative objects the planner reasons about (M of them).

    Attributes
    ----------
    centres : ndarray, shape (M, 3), metres, base frame
    radii : ndarray, shape (M,), metres
    info : ndarray, shape (M, 4, 4), information over ``(centre, radius)`` under the stated box noise
    variance_ratio : ndarray, shape (n_objects,), position variance under the stated / under the model's box noise
    weight : ndarray, shape (M,), 1 for objects, ``discovery_weight`` for tentative ones
    occluded_dirs : list of ndarray, per target, shape (K, 3), unit vectors target -> camera of views where it was hidden
    n_objects : int, the first ``n_objects`` targets are estimated objects, the rest tentative ones
    """

    centres: NDArray[np.float64]
    radii: NDArray[np.float64]
    info: NDArray[np.float64]
    variance_ratio: NDArray[np.float64]
    weight: NDArray[np.float64]
    occluded_dirs: list[NDArray[np.float64]]
    n_objects: int


def ray_workspace_depth(origin: NDArray, direction: NDArray, ws_min: NDArray, ws_max: NDArray) -> tuple[float, float] | None:
    """Entry and exit distance of a ray in an axis-aligned box, or None."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (ws_min - origin) / direction
        t2 = (ws_max - origin) / direction
    lo = np.nanmax(np.minimum(t1, t2))
    hi = np.nanmin(np.maximum(t1, t2))
    if not hi > max(lo, 0.0):
        return None
    return max(lo, 0.0), hi


def tentative_centre(camera: Camera, view: View, bbox_xyxy: Any, cfg: PlannerConfig, workspace: Workspace) -> NDArray[np.float64]:
    """Centre (3,), metres, base frame, of a tentative object for an unexplained box.

    On the ray through the box centre, at the depth where a sphere of ``prior_radius_m`` spans the
    box's angular size, clipped to the part of the ray inside the workspace.
    """
    box = bbox_xyxy
    uv = np.array([[0.5 * (box[0] + box[2]), 0.5 * (box[1] + box[3])]])
    ray_opt = camera.rays(uv)[0]
    ray_opt = ray_opt / np.linalg.norm(ray_opt)
    size = max(0.5 * ((box[2] - box[0]) / camera.fx + (box[3] - box[1]) / camera.fy), MIN_BOX_ANGLE_RAD)
    dist = cfg.prior_radius_m / math.sin(min(0.5 * size, MAX_HALF_ANGLE_RAD))
    Tb = view.T_base_optical
    origin, direction = Tb[:3, 3], Tb[:3, :3] @ ray_opt
    span = ray_workspace_depth(origin, direction, workspace.min, workspace.max)
    if span is not None:
        dist = float(np.clip(dist, *span))
    return origin + dist * direction


def build_targets(state: PlannerState, cfg: PlannerConfig, workspace: Workspace) -> Targets:
    """The estimated objects, then one tentative object per unexplained box, with their information so far."""
    centres = [np.asarray(o.position, dtype=float) for o in state.objects]
    radii = [float(o.radius) if o.radius is not None else cfg.prior_radius_m for o in state.objects]
    weights = [1.0] * len(centres)
    n_obj = len(centres)
    unexplained = state.unexplained
    for v, d in unexplained:
        centres.append(tentative_centre(state.camera, state.views[v], state.views[v].detections[d].bbox_xyxy, cfg, workspace))
        radii.append(cfg.prior_radius_m)
        weights.append(cfg.discovery_weight)
    M = len(centres)
    C = np.array(centres).reshape(M, 3)
    Rd = np.array(radii, dtype=float)
    assoc = [dict(o.associations) for o in state.objects] + [{v: d} for v, d in unexplained]
    info, info_model, occluded = _information_so_far(state, cfg, C, Rd, assoc, n_obj)
    ratio = rms_mm(info[:n_obj]) ** 2 / np.maximum(rms_mm(info_model[:n_obj]) ** 2, np.finfo(float).tiny)
    return Targets(C, Rd, info, ratio, np.array(weights), [np.array(d).reshape(-1, 3) for d in occluded], n_obj)


def _information_so_far(
    state: PlannerState,
    cfg: PlannerConfig,
    C: NDArray[np.float64],
    Rd: NDArray[np.float64],
    assoc: list[dict[int, int]],
    n_obj: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[list[NDArray[np.float64]]]]:
    """Each target's information from the views it was associated in, and the directions it was seen hidden from.

    Returns ``(info, info_model, occluded)``: information (M, 4, 4) under the stated box noise and under the
    sensor model's, and per target the unit vectors target -> camera of views that hid it (missed while
    predicted visible, or seen with an occluded or cut edge).
    """
    cam, views, M = state.camera, state.views, len(C)
    info = np.zeros((M, 4, 4))
    info[:, 3, 3] = 1.0 / cfg.prior_radius_std_m**2
    info[:, :3, :3] = np.eye(3) / POSITION_PRIOR_STD_M**2
    info_model = info.copy()
    occluded: list[list[NDArray[np.float64]]] = [[] for _ in range(M)]
    if not views or not M:
        return info, info_model, occluded
    T_ob = np.stack([np.linalg.inv(v.T_base_optical) for v in views])
    boxes, J, vis, depth = boxes_and_jacobians(cam, T_ob, C, Rd)
    sig = box_edge_sigma_px(cfg.stated_sensor, boxes)
    sig_model = box_edge_sigma_px(cfg.sensor, boxes)
    _, frac = occlusion_by_known(boxes, depth)
    for m in range(M):
        for v, view in enumerate(views):
            j = assoc[m].get(v)
            cam_dir = view.T_base_optical[:3, 3] - C[m]
            cam_dir = cam_dir / max(np.linalg.norm(cam_dir), _MIN_NORM)
            if j is None:
                if m < n_obj and vis[v, m] and frac[v, m] >= HIDDEN_IF_VISIBLE_FRACTION:
                    occluded[m].append(cam_dir)  # predicted visible, not seen: hidden by something unknown
                continue
            obs = np.asarray(view.detections[j].bbox_xyxy, dtype=float)
            pred = boxes[v, m]
            if not np.all(np.isfinite(pred)):
                continue
            w = (inward_edge_offsets(pred, obs) / sig[v, m] <= cfg.occluded_edge_sigma).astype(float)
            w *= border_weights(obs, cam, cfg.border_px)
            if w.sum() < 4:
                occluded[m].append(cam_dir)
            info[m] += fisher(J[v, m], sig[v, m], w)
            info_model[m] += fisher(J[v, m], sig_model[v, m], w)
    return info, info_model, occluded


#: Length below which a direction is not normalised (a camera at the target's centre), metres.
_MIN_NORM = 1e-9


#: Median absolute deviation to standard deviation for normal errors: ``1 / Phi^-1(3/4)``.
MAD_TO_SIGMA = 1.4826
#: Fewest edges beyond the fitted parameters for :func:`estimate_box_noise` to estimate the noise.
MIN_NOISE_DOF = 8
#: Box sizes below this (pixels) are taken as this when dividing an edge residual by the size.
MIN_BOX_SIZE_PX = 1.0


def estimate_box_noise(state: PlannerState, cfg: PlannerConfig) -> float | None:
    """The detector's edge noise as a fraction of the box size, from the boxes seen so far.

    Each associated box is compared with the box its object's current estimate predicts; edges
    on the image border and edges far inside the prediction (occluded: more than
    ``occluded_edge_sigma`` sensor-model sigmas) are left out. The estimate is the robust
    spread ``1.4826 * median(|residual| / size)``, corrected for the 4 parameters fitted per
    object, and at least ``min_box_noise``. None when fewer than 8 edges are left beyond the
    fitted parameters (then the sensor model's ``alpha`` is used).

    Returns
    -------
    float or None
    """
    objs = [o for o in state.objects if o.associations]
    if not objs or not state.views:
        return None
    cam = state.camera
    T_ob = np.stack([np.linalg.inv(v.T_base_optical) for v in state.views])
    C = np.array([o.position for o in objs], dtype=float)
    R = np.array([o.radius if o.radius is not None else cfg.prior_radius_m for o in objs], dtype=float)
    boxes, _, _, _ = boxes_and_jacobians(cam, T_ob, C, R)
    sig = box_edge_sigma_px(cfg.sensor, boxes)
    ratios: list[float] = []
    n_edges = 0
    for m, o in enumerate(objs):
        for v, j in o.associations.items():
            if not 0 <= v < len(state.views) or not 0 <= j < len(state.views[v].detections):
                continue
            pred, obs = boxes[v, m], np.asarray(state.views[v].detections[j].bbox_xyxy, dtype=float)
            if not np.all(np.isfinite(pred)):
                continue
            d = inward_edge_offsets(pred, obs)
            keep = (d <= cfg.occluded_edge_sigma * sig[v, m]) & (border_weights(obs, cam, cfg.border_px) > 0)
            size = np.array([pred[2] - pred[0], pred[3] - pred[1]] * 2)
            ratios += (np.abs(d[keep]) / np.maximum(size[keep], MIN_BOX_SIZE_PX)).tolist()
            n_edges += int(keep.sum())
    dof = n_edges - 4 * len(objs)
    if dof < MIN_NOISE_DOF:
        return None
    alpha = MAD_TO_SIGMA * float(np.median(ratios)) * math.sqrt(n_edges / dof)
    return max(alpha, cfg.min_box_noise)


#: Half side of the planner's default workspace cube around the estimates, metres.
DEFAULT_HALF_EXTENT_M = 0.2
#: Without estimates, the default workspace is centred this far along the first view's optical axis, metres.
DEFAULT_LOOK_AHEAD_M = 0.5


def default_workspace(state: PlannerState, half_extent: float = DEFAULT_HALF_EXTENT_M) -> Workspace:
    """The planner's workspace when none is given: a cube of side ``2 * half_extent`` around the estimates.

    Centre: the mean of the estimated positions; without any, the point 0.5 m along the first view's
    optical axis. Raises InputError for an empty session without a workspace.
    """
    if state.workspace is not None:
        return state.workspace
    if state.objects:
        c = np.mean([o.position for o in state.objects], axis=0)
    elif state.views:
        T = state.views[0].T_base_optical
        c = T[:3, 3] + DEFAULT_LOOK_AHEAD_M * T[:3, 2]
    else:
        raise InputError("workspace: a session without views needs a workspace (or a target) to plan the first view")
    return Workspace(c - half_extent, c + half_extent)
