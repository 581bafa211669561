"""Next-best-view planning: rank candidate camera poses by the expected gain of a view there.

The planner predicts, from the current estimate only (no new posterior per candidate):

**information**
    Every estimated object ``i`` (centre ``c``, radius ``r``) has an information matrix
    ``L_i`` (4 x 4 over ``(c, r)``) rebuilt from the views it was associated in: the Fisher
    information ``J^T W J`` of its four predicted box edges under the ``bayes`` sensor model
    (edge noise ``sigma = alpha * size + sigma0_px``, :class:`~monovisual3d.methods.bayes.likelihood.SensorModel`),
    leaving out the edges the observed box shows occluded (inside the prediction by more than
    ``occluded_edge_sigma``) or cut by the image border. A candidate adds ``J^T W J`` of its
    own predicted box, each edge weighted by its visibility. The gain of object ``i`` is the
    expected drop of its RMS position error ``s = sqrt(trace of the position block of L^-1)``,
    in millimetres, capped at ``cap_mm`` (an object known worse than that counts as not localised).
**visibility**
    Per candidate and object: in front of the camera and inside the image (edges cut by
    the border carry nothing), occlusion by nearer estimated fruit (sample points of the
    predicted disc covered by nearer discs; an edge carries what its points show; below
    ``min_visible_fraction`` of the disc, no detection is expected), and a prior probability
    ``p_occluder`` that an unknown occluder (a leaf) hides it, raised towards ``p_occluder_seen``
    for candidates whose viewing direction is close (``occluder_angle_deg``) to a past view in
    which the object was predicted visible but missed, or seen with occluded edges.
**discovery**
    A box no object explains (a fruit seen once, a fruit the others hide, a false positive) is
    a tentative object on the box's ray at the depth a fruit of ``prior_radius_m`` would have,
    with the information of that one view plus a radius prior: its gain is computed as for an
    object, times ``discovery_weight``. The workspace's volume seen by fewer than two views
    adds ``coverage_mm`` times the fraction of it a candidate would newly cover (this decides
    the first view of an empty session).
**motion**
    ``motion_weight * (distance + rotation_scale_m * angle)`` from the current pose
    (the last view's; in a batch, the previous pick's), subtracted from the gain (mm per metre).

Batch mode (``count=k``) is greedy on the joint information: after each pick the expected
information of that view is added to every object and the next view is ranked again.

Stopping rule: ``done`` when there are at least two views, every object's 95 % position
error ellipsoid has its largest semi-axis within ``target_mm``
and no box is unexplained. With ``joint_confidence`` (default) the 95 % is for all objects at
once: each ellipsoid is taken at the ``0.95 ** (1 / n)`` quantile (1.22 times larger for six).
The ellipsoid is the larger of the method's (scaled to the box noise) and the one of the planner's
own information, which counts nothing from edges seen occluded.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..errors import InputError
from ..geometry.sphere import predict_sphere_boxes as predict_boxes
from ..methods.bayes.likelihood import SensorModel
from ..result import DetectedObject, Result
from ..session import Session, View, Workspace
from .candidates import check_candidates

#: chi-square quantile, 3 degrees of freedom, 95 %: the 95 % ellipsoid's semi-axes are sqrt(CHI2_3_95 * eigenvalues).
CHI2_3_95 = 7.814727903251178
#: Finite-difference step of the box Jacobian, metres.
_H = 1e-5
#: Sample points of a predicted disc (unit disc coordinates): 3 per edge (left, top, right, bottom), then interior.
_EDGE_ANGLES = np.radians([180.0, 160.0, 200.0, 270.0, 250.0, 290.0, 0.0, 20.0, -20.0, 90.0, 70.0, 110.0])
_EDGE_OF_POINT = np.repeat(np.arange(4), 3)  # image y is down: angle 270 deg (v = -1) is the top edge
_DISC_POINTS = np.concatenate(
    [
        0.85 * np.stack([np.cos(_EDGE_ANGLES), np.sin(_EDGE_ANGLES)], -1),
        0.5 * np.stack([np.cos(np.radians(np.arange(0, 360, 60))), np.sin(np.radians(np.arange(0, 360, 60)))], -1),
        np.zeros((1, 2)),
    ]
)


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
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
                raise InputError(f"{name}: got {v!r}, expected a positive number")
        for name in ("motion_weight", "discovery_weight", "coverage_mm", "border_px", "occluded_edge_sigma"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v >= 0):
                raise InputError(f"{name}: got {v!r}, expected a finite number >= 0")
        for name in ("p_occluder", "p_occluder_seen", "min_visible_fraction"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0 <= v < 1):
                raise InputError(f"{name}: got {v!r}, expected a probability in [0, 1)")
        if (
            self.box_noise is not None
            and self.box_noise != "auto"
            and not (
                isinstance(self.box_noise, (int, float))
                and not isinstance(self.box_noise, bool)
                and math.isfinite(self.box_noise)
                and self.box_noise >= 0
            )
        ):
            raise InputError(f"box_noise: got {self.box_noise!r}, expected a fraction >= 0 or 'auto'")
        if not (isinstance(self.min_box_noise, (int, float)) and 0 <= self.min_box_noise < 1):
            raise InputError(f"min_box_noise: got {self.min_box_noise!r}, expected a fraction in [0, 1)")
        if not (isinstance(self.reach_m, (int, float)) and self.reach_m > 0):
            raise InputError(f"reach_m: got {self.reach_m!r}, expected a positive number of metres")
        if not isinstance(self.joint_confidence, bool):
            raise InputError(f"joint_confidence: got {self.joint_confidence!r}, expected true or false")
        if isinstance(self.coverage_points, bool) or not isinstance(self.coverage_points, int) or self.coverage_points < 2:
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


@dataclass(frozen=True)
class Plan:
    """The planner's answer.

    Attributes
    ----------
    indices : tuple of int, chosen candidates (index in the given list), in order
    poses : ndarray, shape (k, 4, 4), their ``T_base_optical``
    gains : tuple of float, expected gain of each pick when it was picked (mm)
    ranking : ndarray, shape (N,), int, candidates ordered by first-pick gain (ties: lower index first)
    scores : ndarray, shape (N,), float, first-pick gain of every candidate (-inf: unreachable)
    components : dict of ndarray (N,), first-pick ``information``, ``discovery``, ``coverage``, ``motion``
    done : bool, the stopping rule
    ellipsoid_mm : ndarray, shape (M,), largest 95 % semi-axis of each object now, millimetres
    unexplained : list of (view, detection), boxes no object explains
    target_gains : ndarray, shape (N, M + U), first-pick expected gain (mm) of every candidate for every
        object (M, in the order given) and every tentative object (U, one per unexplained box)
    timing_s : float, planning time (without the localisation)
    box_noise : float, the box noise (fraction of the box size) the plan used: stated, estimated
        (``box_noise="auto"``) or the sensor model's
    """

    indices: tuple[int, ...]
    poses: NDArray[np.float64]
    gains: tuple[float, ...]
    ranking: NDArray[np.intp]
    scores: NDArray[np.float64]
    components: dict[str, NDArray[np.float64]]
    done: bool
    ellipsoid_mm: NDArray[np.float64]
    unexplained: list[tuple[int, int]]
    target_gains: NDArray[np.float64]
    timing_s: float = 0.0
    box_noise: float = 0.05

    @property
    def index(self) -> int:
        """The first chosen candidate."""
        return self.indices[0]

    @property
    def gain(self) -> float:
        return self.gains[0]

    def to_dict(self, pose_frame: str = "optical") -> dict[str, Any]:
        """JSON-ready dict: ``index``, ``pose``, ``gain``, ``ranking``, ``done`` (+ lists for a batch)."""
        from .candidates import pose_to_dict

        ranking = [
            {"index": int(i), "gain": float(self.scores[i]) if np.isfinite(self.scores[i]) else None} for i in self.ranking
        ]
        out: dict[str, Any] = {
            "index": int(self.index),
            "pose": pose_to_dict(self.poses[0], pose_frame),
            "gain": float(self.gain),
            "ranking": ranking,
            "done": bool(self.done),
            "ellipsoid95_mm": [float(x) for x in self.ellipsoid_mm],
            "unexplained": [{"view": v, "detection": d} for v, d in self.unexplained],
            "box_noise": float(self.box_noise),
            "pose_frame": pose_frame,
        }
        if len(self.indices) > 1:
            out["indices"] = [int(i) for i in self.indices]
            out["poses"] = [pose_to_dict(T, pose_frame) for T in self.poses]
            out["gains"] = [float(g) for g in self.gains]
        return out


# ----------------------------------------------------------------------------- geometry
def boxes_and_jacobians(
    camera: Camera, T_optical_base: NDArray[np.floating], centres: NDArray[np.floating], radii: NDArray[np.floating]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """Predicted boxes of spheres in several views and their Jacobians w.r.t. ``(centre, radius)``.

    Parameters
    ----------
    camera : Camera
    T_optical_base : ndarray, shape (V, 4, 4)
    centres : ndarray, shape (M, 3), metres, base frame
    radii : ndarray, shape (M,), metres

    Returns
    -------
    boxes : ndarray, shape (V, M, 4), pixels (x1, y1, x2, y2), NaN where not in front
    J : ndarray, shape (V, M, 4, 4), d edges / d (x, y, z, r), pixels per metre, base frame
    visible : ndarray, shape (V, M), bool, in front and overlapping the image
    depth : ndarray, shape (V, M), metres, optical z of the centre
    """
    R = T_optical_base[:, :3, :3]
    t = T_optical_base[:, :3, 3]
    p = np.einsum("vij,mj->vmi", R, centres) + t[:, None, :]  # (V, M, 3)
    V, M = p.shape[:2]
    r = np.broadcast_to(radii, (V, M))
    steps = np.zeros((9, 4))
    steps[1:7, :3] = np.repeat(np.eye(3), 2, axis=0) * np.tile([_H, -_H], 3)[:, None]
    steps[7:, 3] = [_H, -_H]
    P = p[None] + steps[:, None, None, :3]  # (9, V, M, 3)
    Rr = r[None] + steps[:, None, None, 3]
    b, vis = predict_boxes(camera, P.reshape(-1, 3), Rr.reshape(-1, 1))
    b = b.reshape(9, V, M, 4)
    d_opt = np.stack([(b[1 + 2 * k] - b[2 + 2 * k]) / (2 * _H) for k in range(3)], axis=-1)  # (V, M, 4, 3)
    d_r = (b[7] - b[8]) / (2 * _H)  # (V, M, 4)
    J = np.concatenate([np.einsum("vmek,vkj->vmej", d_opt, R), d_r[..., None]], axis=-1)
    return b[0], J, vis.reshape(9, V, M)[0], p[..., 2]


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
    sig = edge_sigma_px(boxes, cfg.sensor)
    ratios: list[float] = []
    n_edges = 0
    for m, o in enumerate(objs):
        for v, j in o.associations.items():
            if not 0 <= v < len(state.views) or not 0 <= j < len(state.views[v].detections):
                continue
            pred, obs = boxes[v, m], np.asarray(state.views[v].detections[j].bbox_xyxy, dtype=float)
            if not np.all(np.isfinite(pred)):
                continue
            d = np.array([obs[0] - pred[0], obs[1] - pred[1], pred[2] - obs[2], pred[3] - obs[3]])
            keep = (d <= cfg.occluded_edge_sigma * sig[v, m]) & (border_weights(obs, cam, cfg.border_px) > 0)
            size = np.array([pred[2] - pred[0], pred[3] - pred[1]] * 2)
            ratios += (np.abs(d[keep]) / np.maximum(size[keep], 1.0)).tolist()
            n_edges += int(keep.sum())
    dof = n_edges - 4 * len(objs)
    if dof < 8:
        return None
    alpha = 1.4826 * float(np.median(ratios)) * math.sqrt(n_edges / dof)
    return max(alpha, cfg.min_box_noise)


def edge_sigma_px(boxes: NDArray[np.floating], sensor: SensorModel) -> NDArray[np.float64]:
    """Edge noise of predicted boxes (..., 4): ``alpha * size + sigma0_px``, pixels."""
    w = boxes[..., 2] - boxes[..., 0]
    h = boxes[..., 3] - boxes[..., 1]
    sx = sensor.alpha * w + sensor.sigma0_px
    sy = sensor.alpha * h + sensor.sigma0_px
    return np.stack([sx, sy, sx, sy], axis=-1)


def fisher(J: NDArray[np.floating], sigma: NDArray[np.floating], weight: NDArray[np.floating]) -> NDArray[np.float64]:
    """``J^T diag(weight / sigma^2) J`` over the last two axes: J (..., 4, 4), sigma and weight (..., 4)."""
    w = np.nan_to_num(weight / sigma**2)
    Jn = np.nan_to_num(J)
    return np.einsum("...ei,...e,...ej->...ij", Jn, w, Jn)


def border_weights(boxes: NDArray[np.floating], camera: Camera, border_px: float) -> NDArray[np.float64]:
    """1 for an edge inside the image, 0 for an edge cut by (or within ``border_px`` of) the border, shape (..., 4)."""
    x1, y1, x2, y2 = (boxes[..., k] for k in range(4))
    ok = np.stack([x1 > border_px, y1 > border_px, x2 < camera.width - border_px, y2 < camera.height - border_px], axis=-1)
    return ok.astype(float)


def occlusion_by_known(
    boxes: NDArray[np.floating], depth: NDArray[np.floating]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Visibility of each predicted disc behind the nearer ones, per edge and overall.

    Parameters
    ----------
    boxes : ndarray, shape (..., M, 4), predicted boxes (one view per leading index)
    depth : ndarray, shape (..., M), optical depth of the centres, metres

    Returns
    -------
    edge_visible : ndarray, shape (..., M, 4), fraction of each edge's sample points not covered by a nearer disc
    visible : ndarray, shape (..., M), fraction of all sample points not covered
    """
    centre = 0.5 * (boxes[..., :2] + boxes[..., 2:])  # (..., M, 2)
    half = 0.25 * ((boxes[..., 2] - boxes[..., 0]) + (boxes[..., 3] - boxes[..., 1]))  # (..., M)
    pts = centre[..., :, None, :] + half[..., :, None, None] * _DISC_POINTS  # (..., M, P, 2)
    # covered[..., i, p] = any j nearer than i whose disc contains point p of i
    d = pts[..., :, None, :, :] - centre[..., None, :, None, :]  # (..., Mi, Mj, P, 2)
    inside = (d**2).sum(-1) < (half[..., None, :, None] ** 2)
    nearer = depth[..., None, :] < depth[..., :, None]  # (..., Mi, Mj)
    covered = (inside & nearer[..., None]).any(axis=-2)  # (..., Mi, P)
    covered = np.where(np.isnan(centre[..., :1]), True, covered)
    free = ~covered
    n_edge = 12
    edge_visible = free[..., :n_edge].reshape(free.shape[:-1] + (4, 3)).mean(-1)
    return edge_visible, free.mean(-1)


# ----------------------------------------------------------------------------- state
@dataclass
class _Targets:
    """Objects and tentative objects the planner reasons about (M of them)."""

    centres: NDArray[np.float64]  # (M, 3)
    radii: NDArray[np.float64]  # (M,)
    info: NDArray[np.float64]  # (M, 4, 4), under the stated box noise
    variance_ratio: NDArray[np.float64]  # (n_objects,), position variance stated / under the model's alpha
    weight: NDArray[np.float64]  # (M,) 1 for objects, discovery_weight for tentative ones
    occluded_dirs: list[NDArray[np.float64]]  # per target, (K, 3) unit vectors target -> camera of views where it was hidden
    n_objects: int


def _ray_workspace_depth(origin: NDArray, direction: NDArray, ws_min: NDArray, ws_max: NDArray) -> tuple[float, float] | None:
    """Entry and exit distance of a ray in an axis-aligned box, or None."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (ws_min - origin) / direction
        t2 = (ws_max - origin) / direction
    lo = np.nanmax(np.minimum(t1, t2))
    hi = np.nanmin(np.maximum(t1, t2))
    if not hi > max(lo, 0.0):
        return None
    return max(lo, 0.0), hi


def _targets(state: PlannerState, cfg: PlannerConfig, workspace: Workspace) -> _Targets:
    cam, sensor = state.camera, cfg.sensor
    views = state.views
    T_ob = np.stack([np.linalg.inv(v.T_base_optical) for v in views]) if views else np.zeros((0, 4, 4))
    centres, radii, weights = [], [], []
    for o in state.objects:
        centres.append(np.asarray(o.position, dtype=float))
        radii.append(float(o.radius) if o.radius is not None else cfg.prior_radius_m)
        weights.append(1.0)
    n_obj = len(centres)
    # tentative objects: unexplained boxes, on their ray at the depth a fruit of prior radius would have
    unexplained = state.unexplained
    for v, d in unexplained:
        box = views[v].detections[d].bbox_xyxy
        uv = np.array([[0.5 * (box[0] + box[2]), 0.5 * (box[1] + box[3])]])
        ray_opt = cam.rays(uv)[0]
        ray_opt = ray_opt / np.linalg.norm(ray_opt)
        size = max(0.5 * ((box[2] - box[0]) / cam.fx + (box[3] - box[1]) / cam.fy), 1e-4)
        dist = cfg.prior_radius_m / math.sin(min(0.5 * size, 1.0))
        Tb = views[v].T_base_optical
        origin, direction = Tb[:3, 3], Tb[:3, :3] @ ray_opt
        span = _ray_workspace_depth(origin, direction, workspace.min, workspace.max)
        if span is not None:
            dist = float(np.clip(dist, *span))
        centres.append(origin + dist * direction)
        radii.append(cfg.prior_radius_m)
        weights.append(cfg.discovery_weight)
    M = len(centres)
    C = np.array(centres).reshape(M, 3)
    Rd = np.array(radii, dtype=float)
    info = np.zeros((M, 4, 4))
    info[:, 3, 3] = 1.0 / cfg.prior_radius_std_m**2
    info[:, :3, :3] = np.eye(3) / 1.0**2  # 1 m position prior: keeps the matrix invertible
    info_model = info.copy()
    occluded: list[list[NDArray[np.float64]]] = [[] for _ in range(M)]
    if views and M:
        boxes, J, vis, depth = boxes_and_jacobians(cam, T_ob, C, Rd)
        sig = edge_sigma_px(boxes, cfg.stated_sensor)
        sig_model = edge_sigma_px(boxes, sensor)
        edge_free, frac = occlusion_by_known(boxes, depth)
        assoc = [dict(o.associations) for o in state.objects] + [{v: d} for v, d in unexplained]
        for m in range(M):
            for v, view in enumerate(views):
                j = assoc[m].get(v)
                cam_dir = views[v].T_base_optical[:3, 3] - C[m]
                cam_dir = cam_dir / max(np.linalg.norm(cam_dir), 1e-9)
                if j is None:
                    if m < n_obj and vis[v, m] and frac[v, m] >= 0.5:
                        occluded[m].append(cam_dir)  # predicted visible, not seen: hidden by something unknown
                    continue
                obs = view.detections[j].bbox_xyxy
                pred = boxes[v, m]
                if not np.all(np.isfinite(pred)):
                    continue
                inward = np.array([obs[0] - pred[0], obs[1] - pred[1], pred[2] - obs[2], pred[3] - obs[3]]) / sig[v, m]
                w = (inward <= cfg.occluded_edge_sigma).astype(float)
                w *= border_weights(obs, cam, cfg.border_px)
                if w.sum() < 4:
                    occluded[m].append(cam_dir)
                info[m] += fisher(J[v, m], sig[v, m], w)
                info_model[m] += fisher(J[v, m], sig_model[v, m], w)
    ratio = _rms_mm(info[:n_obj]) ** 2 / np.maximum(_rms_mm(info_model[:n_obj]) ** 2, 1e-300)
    return _Targets(C, Rd, info, ratio, np.array(weights), [np.array(d).reshape(-1, 3) for d in occluded], n_obj)


def _rms_mm(info: NDArray[np.floating]) -> NDArray[np.float64]:
    """RMS position error (mm) from information matrices (..., 4, 4)."""
    cov = np.linalg.inv(info)
    return 1e3 * np.sqrt(np.clip(np.trace(cov[..., :3, :3], axis1=-2, axis2=-1), 0.0, None))


def ellipsoid95_mm(covariance: ArrayLike) -> float:
    """Largest semi-axis of the 95 % error ellipsoid of a (3, 3) position covariance (m^2), millimetres.

    Examples
    --------
    >>> round(ellipsoid95_mm(np.eye(3) * 1e-6), 3)  # 1 mm std per axis
    2.795
    """
    S = np.asarray(covariance, dtype=float)
    return float(1e3 * math.sqrt(CHI2_3_95 * max(float(np.linalg.eigvalsh(S)[-1]), 0.0)))


# ----------------------------------------------------------------------------- scoring
def _candidate_terms(
    state: PlannerState,
    cfg: PlannerConfig,
    tg: _Targets,
    T_ob: NDArray[np.float64],
    cand_dirs_pos: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per candidate and target: expected Fisher information (N, M, 4, 4) and detection probability (N, M)."""
    cam = state.camera
    N, M = len(T_ob), len(tg.centres)
    if M == 0:
        return np.zeros((N, 0, 4, 4)), np.zeros((N, 0))
    boxes, J, vis, depth = boxes_and_jacobians(cam, T_ob, tg.centres, tg.radii)
    sig = edge_sigma_px(boxes, cfg.stated_sensor)
    edge_free, frac = occlusion_by_known(boxes, np.where(np.isnan(depth), np.inf, depth))
    w_edge = border_weights(boxes, cam, cfg.border_px) * edge_free
    seen = vis & (frac >= cfg.min_visible_fraction)
    # unknown occluders: a prior, raised near directions in which the target was hidden before
    p_occ = np.full((N, M), cfg.p_occluder)
    s = math.radians(cfg.occluder_angle_deg)
    for m, dirs in enumerate(tg.occluded_dirs):
        if len(dirs) == 0:
            continue
        to_cam = cand_dirs_pos - tg.centres[m]
        to_cam /= np.linalg.norm(to_cam, axis=1, keepdims=True)
        ang = np.arccos(np.clip(to_cam @ dirs.T, -1.0, 1.0))  # (N, K)
        near = np.exp(-0.5 * (ang / s) ** 2).max(axis=1)
        p_occ[:, m] = cfg.p_occluder + (cfg.p_occluder_seen - cfg.p_occluder) * near
    p_det = np.where(seen, 1.0 - p_occ, 0.0)
    F = fisher(J, sig, np.where(seen[..., None], w_edge, 0.0))
    return F, p_det


def _coverage_setup(state: PlannerState, cfg: PlannerConfig, workspace: Workspace) -> tuple[NDArray, NDArray]:
    """Workspace sample points (P, 3) and how many views so far see each (P,)."""
    n = cfg.coverage_points
    axes = [np.linspace(lo, hi, n) for lo, hi in zip(workspace.min, workspace.max)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    count = np.zeros(len(pts))
    for v in state.views:
        count += _sees(state.camera, np.linalg.inv(v.T_base_optical)[None], pts)[0]
    return pts, count


def _sees(camera: Camera, T_ob: NDArray[np.float64], pts: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(N, P): point in front of camera n and projected inside its image."""
    p = np.einsum("nij,pj->npi", T_ob[:, :3, :3], pts) + T_ob[:, None, :3, 3]
    z = p[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = camera.fx * p[..., 0] / z + camera.cx
        v = camera.fy * p[..., 1] / z + camera.cy
    return (z > 0.05) & (u >= 0) & (u <= camera.width) & (v >= 0) & (v <= camera.height)


def _motion(T_from: NDArray[np.float64] | None, T_cand: NDArray[np.float64], cfg: PlannerConfig) -> NDArray[np.float64]:
    """Motion cost (N,) from one pose to each candidate (0 without a current pose or with motion_weight 0)."""
    if T_from is None or cfg.motion_weight == 0:
        return np.zeros(len(T_cand))
    dist = np.linalg.norm(T_cand[:, :3, 3] - T_from[:3, 3], axis=1)
    Rrel = np.einsum("ji,njk->nik", T_from[:3, :3], T_cand[:, :3, :3])
    ang = np.arccos(np.clip((np.trace(Rrel, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0))
    return cfg.motion_weight * (dist + cfg.rotation_scale_m * ang)


def _ellipsoids(state: PlannerState, tg: _Targets) -> NDArray[np.float64]:
    """Largest 95 % semi-axis per object, mm: the method's covariance (scaled to the stated box noise) or, when
    larger, the one of the planner's own information, which counts nothing from edges seen occluded (a box a
    leaf cuts says little, however exact the detector)."""
    out = []
    for o, k, info in zip(state.objects, tg.variance_ratio, tg.info):
        if o.covariance is None:
            out.append(math.inf)
            continue
        own = np.linalg.inv(info)[:3, :3]
        out.append(max(ellipsoid95_mm(np.asarray(o.covariance) * k), ellipsoid95_mm(own)))
    return np.array(out)


def stop_scale(n_objects: int, cfg: PlannerConfig) -> float:
    """Factor on each 95 % ellipsoid's semi-axis in the stopping rule.

    With ``joint_confidence`` the 95 % holds for all ``n_objects`` fruit at once: each fruit's
    ellipsoid is taken at the ``0.95 ** (1 / n)`` quantile (Sidak), e.g. 1.22 times the 95 % one
    for six fruit; otherwise 1.

    Examples
    --------
    >>> round(stop_scale(6, PlannerConfig()), 3), stop_scale(6, PlannerConfig(joint_confidence=False))
    (1.223, 1.0)
    """
    if not cfg.joint_confidence or n_objects <= 1:
        return 1.0
    from scipy.stats import chi2

    return math.sqrt(float(chi2.ppf(0.95 ** (1.0 / n_objects), 3)) / CHI2_3_95)


def default_workspace(state: PlannerState, half_extent: float = 0.2) -> Workspace:
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
        c = T[:3, 3] + 0.5 * T[:3, 2]
    else:
        raise InputError("workspace: a session without views needs a workspace (or a target) to plan the first view")
    return Workspace(c - half_extent, c + half_extent)


def plan_from_state(state: PlannerState, candidates: ArrayLike, *, count: int = 1, config: PlannerConfig | None = None) -> Plan:
    """Rank candidates for an explicit :class:`PlannerState` (see :func:`plan_next_view`)."""
    t0 = time.perf_counter()
    cfg = config or PlannerConfig()
    T_cand = check_candidates(candidates)
    N = len(T_cand)
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise InputError(f"count: got {count!r}, expected a positive integer")
    reachable = np.linalg.norm(T_cand[:, :3, 3] - np.asarray(cfg.base_centre), axis=1) <= cfg.reach_m
    if count > int(reachable.sum()):
        raise InputError(f"count: got {count}, but only {int(reachable.sum())} of {N} candidates are reachable")
    workspace = default_workspace(state)
    if cfg.box_noise == "auto":
        estimated = estimate_box_noise(state, cfg)
        cfg = replace(cfg, box_noise=estimated)  # None (too few boxes yet): the sensor model's alpha
    tg = _targets(state, cfg, workspace)
    T_ob = np.linalg.inv(T_cand)
    F, p_det = _candidate_terms(state, cfg, tg, T_ob, T_cand[:, :3, 3])
    pts, cov_count = _coverage_setup(state, cfg, workspace)
    sees = _sees(state.camera, T_ob, pts)  # (N, P)
    cap = cfg.cap_mm
    info = tg.info.copy()
    current = state.views[-1].T_base_optical if state.views else None
    picked: list[int] = []
    gains: list[float] = []
    components: dict[str, NDArray[np.float64]] = {}
    first_scores = np.full(N, -np.inf)
    target_gains = np.zeros((N, len(tg.centres)))
    for step in range(int(count)):
        s_now = np.minimum(_rms_mm(info), cap)  # (M,)
        s_new = np.minimum(_rms_mm(info[None] + F), cap)  # (N, M)
        per = p_det * (s_now[None] - s_new) * tg.weight[None]  # (N, M)
        obj_gain = per[:, : tg.n_objects].sum(axis=1)
        disc_gain = per[:, tg.n_objects :].sum(axis=1)
        need = np.clip(2 - cov_count, 0, None)
        cov_gain = cfg.coverage_mm * (sees * need[None]).sum(axis=1) / max(2.0 * len(pts), 1.0)
        motion = _motion(current, T_cand, cfg)
        total = obj_gain + disc_gain + cov_gain - motion
        total = np.where(reachable, total, -np.inf)
        if picked:
            total[picked] = -np.inf
        if step == 0:
            first_scores = total.copy()
            components = {"information": obj_gain, "discovery": disc_gain, "coverage": cov_gain, "motion": motion}
            target_gains = per
        best = int(np.argmax(total))  # first maximum: ties go to the lower index
        picked.append(best)
        gains.append(float(total[best]))
        info = info + p_det[best][:, None, None] * F[best]
        cov_count = cov_count + sees[best]
        current = T_cand[best]
    ranking = np.lexsort((np.arange(N), -np.where(np.isfinite(first_scores), first_scores, -1e300)))
    ell = _ellipsoids(state, tg)
    unexplained = state.unexplained
    done = len(state.views) >= 2 and not unexplained and bool(np.all(ell * stop_scale(len(ell), cfg) <= cfg.target_mm))
    return Plan(
        indices=tuple(picked),
        poses=T_cand[picked],
        gains=tuple(gains),
        ranking=ranking,
        scores=first_scores,
        components=components,
        done=done,
        ellipsoid_mm=ell,
        unexplained=unexplained,
        target_gains=target_gains,
        timing_s=time.perf_counter() - t0,
        box_noise=cfg.stated_sensor.alpha,
    )


def load_planning_session(source: str | Path | dict[str, Any] | Session) -> Session:
    """:func:`monovisual3d.load_session`, also accepting a session with no views yet (``"views": []``).

    The planner needs only the camera and the workspace before the first view.
    """
    from ..session import camera_from_dict, load_session, read_structured_file, workspace_from_dict

    if isinstance(source, Session):
        return source
    data = read_structured_file(source) if isinstance(source, (str, Path)) else source
    if isinstance(data, dict) and data.get("views") == []:
        name = str(source) if isinstance(source, (str, Path)) else None
        try:
            camera = camera_from_dict(data.get("camera"))
            ws = workspace_from_dict(data["workspace"], "workspace") if data.get("workspace") is not None else None
        except InputError as exc:
            raise InputError(f"{name}: {exc}" if name else str(exc)) from None
        return Session(camera, (), ws, name)
    return load_session(data if not isinstance(source, (str, Path)) else source)


def plan_next_view(
    session_or_localizer: Any,
    candidates: ArrayLike,
    *,
    count: int = 1,
    objects: Result | list[DetectedObject] | None = None,
    workspace: Workspace | None = None,
    config: PlannerConfig | None = None,
    localize_options: dict[str, Any] | None = None,
    **options: Any,
) -> Plan:
    """Choose the next camera pose(s) from candidates by expected gain; report whether to stop.

    Parameters
    ----------
    session_or_localizer : Session, path, dict, or :class:`monovisual3d.methods.bayes.BayesLocalizer`
        The views so far. A session is localised with the ``bayes`` method (``localize_options``)
        unless ``objects`` is given; a localizer's :meth:`estimate` is used likewise.
    candidates : array_like, shape (N, 4, 4), ``T_base_optical`` of each candidate
        (see :mod:`monovisual3d.active.candidates` for files and caps)
    count : int, views to choose jointly (greedy on the joint information)
    objects : Result or list of DetectedObject, optional, the current estimate (avoids localising again)
    workspace : Workspace, optional, overrides the session's (default: a 0.4 m cube around the estimates)
    config : PlannerConfig, optional
    **options : fields of :class:`PlannerConfig` (e.g. ``motion_weight``, ``target_mm``, ``reach_m``)

    Returns
    -------
    Plan

    Examples
    --------
    >>> from monovisual3d.sim import paper_scene, simulate
    >>> from monovisual3d.active.candidates import CapSpec, cap_poses
    >>> session, _ = simulate(paper_scene(), rng=0)
    >>> plan = plan_next_view(session, cap_poses(CapSpec(n=20), [0.6, 0.0, 0.45]))
    >>> 0 <= plan.index < 20
    True
    """
    if config is not None and options:
        raise InputError("config and keyword options: give one or the other")
    try:
        cfg = config or PlannerConfig(**options)
    except TypeError as exc:
        raise InputError(f"plan_next_view: {exc}") from None
    try:
        from ..methods.bayes import BayesLocalizer
    except ImportError:  # pragma: no cover
        BayesLocalizer = ()  # type: ignore[assignment,misc]
    if isinstance(session_or_localizer, BayesLocalizer):
        loc = session_or_localizer
        camera, views, ws = loc.camera, tuple(loc.views), loc.workspace
        if objects is None:
            objects = loc.estimate()
    else:
        if isinstance(session_or_localizer, (str, Path, dict, Session)):
            session = load_planning_session(session_or_localizer)
        else:
            raise InputError(
                f"session_or_localizer: expected a Session, path or BayesLocalizer, got {type(session_or_localizer).__name__}"
            )
        camera, views, ws = session.camera, session.views, session.workspace
        if objects is None:
            n_with = sum(1 for v in views if v.detections)
            if n_with >= 2:
                import warnings

                from ..api import localize

                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    objects = localize(session, method="bayes", **(localize_options or {}))
            else:
                objects = []
    objs = objects.objects if isinstance(objects, Result) else list(objects)
    state = PlannerState(camera, tuple(views), tuple(objs), workspace or ws)
    return plan_from_state(state, candidates, count=count, config=cfg)
