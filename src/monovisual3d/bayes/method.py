"""The ``bayes`` method: ghost-free, size-aware localisation (the default).

Pipeline
--------
1. **Hypotheses.** State = (cell centre, radius bin). Cells come from a
   coarse-to-fine search of the viewing-cone intersections
   (:mod:`.search`); radii are ``n_radii`` log-spaced bins in
   ``[radius_min, radius_max]``.
2. **Score.** Each hypothesis gets the sum over views of the box
   log-likelihood ratio of :mod:`.likelihood` (best-matching box per view, a
   miss term, no information outside the field of view). The grid cell's own
   projected size is added to the edge noise, so a cell is scored as the
   region it stands for. ``exp(score)`` normalised over the hypotheses is the
   posterior.
3. **Extraction without k (greedy explaining-away).** Take the best
   hypothesis; refine it (:mod:`.refine`); re-associate its boxes at the
   refined sphere and refine again if they changed. It is **accepted** when
   at least ``min_views`` views have a box associated to it and its refined
   score is at least ``accept`` nats. An accepted object removes its boxes
   from every view and the scores are recomputed; a rejected one suppresses
   the hypotheses around it. Stop when the best remaining grid score is
   below ``accept - prune_slack`` (a grid score is blurred by the cell, so
   candidates slightly below ``accept`` are still refined). Ghosts (cone intersections of different fruit) lose: their
   implied sizes disagree between views and they have no box in the other
   views, and once the real fruit have taken the boxes, nothing is left.
   Two local repairs of the greedy association follow: overlapping objects
   swap their boxes in a view when that fits both better, and a fruit left
   with one view gets back a box a neighbour took when the neighbour can do
   without it (the total score must grow by more than ``accept``).
4. **Imperfect poses (optional).** With a stated pose uncertainty
   (``pose_sigma_mm``, ``pose_sigma_deg``: 1-sigma per axis of the arm's
   kinematics and hand-eye calibration), the edge noise of steps 2-3 gets the
   pose uncertainty projected into pixels (``f * sigma_p / depth`` and
   ``f * sigma_rot``, in quadrature, :func:`.likelihood.pose_sigma_px`), so
   boxes shifted by pose error are not rejected; and after extraction all
   objects are refined jointly with a small pose correction per view under
   Gaussian priors of those sizes (:mod:`.bundle`). With both at 0 (the
   default) the poses are taken as exact and neither happens.
5. **Outputs.** Position, radius, position covariance (Gauss-Newton at the
   refined solution, or the joint solution's marginal block), score (nats),
   and the association ``view -> detection``. With a pose uncertainty, the
   estimated pose corrections are in ``Result.config["pose_corrections"]``.
"""

from __future__ import annotations

import numbers
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from itertools import combinations
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from ..errors import InputError, InputWarning
from ..frames import invert_transform, transform_points
from ..grid import DEFAULT_REACH_M, VoxelGrid
from ..localize import register_method
from ..result import DetectedObject, Result
from ..session import Session, View, Workspace
from ._kernels import HAVE_NUMBA, cone_counts_fused, score_hypotheses
from .bundle import bundle_adjust, correction_transform
from .likelihood import SensorModel, box_scores, pose_sigma_px, predict_boxes, view_scores
from .masks import contour_points
from .refine import Observation, refine_sphere
from .search import cone_counts, split_cells

_RADIUS_MARGIN_BINS = 1


def _is_real(v: Any) -> bool:
    """A real number (Python or numpy), not a bool."""
    return isinstance(v, (numbers.Real, np.floating, np.integer)) and not isinstance(v, (bool, np.bool_))


@dataclass(frozen=True)
class BayesConfig:
    """Options of the ``bayes`` method.

    Attributes
    ----------
    resolution : float, metres, cell size of the scored grid (accuracy comes from the continuous refinement;
        0.02 is ~15% faster and gives the same estimates on unoccluded scenes, but lost fruit and made one
        false one under occlusion with noisy boxes in the accuracy benchmark)
    coarse_resolution : float, metres, cell size of the first search level (``resolution`` if that is coarser)
    radius_min, radius_max : float, metres, range of object radii
    n_radii : int, log-spaced radius bins
    reach : float, metres, manipulator reach R (paper's cube of side 2R) when no workspace is given
    accept : float, nats, minimum refined score of an object
    min_views : int, minimum number of views with an associated box
    use_masks : bool, use instance masks in the refinement when detections carry them
    alpha, sigma0_px, inward_floor, outward_floor, match_bonus, p_miss, border_px :
        the sensor model, see :class:`monovisual3d.bayes.likelihood.SensorModel`
    lookahead, lookahead_margin : int, float (nats): at each extraction step, refine up to
        ``lookahead`` distinct candidates whose grid score is within ``lookahead_margin`` of the best
        and keep the best refined one (1 = plain greedy); the steal pass also tries up to ``lookahead``
        candidates
    prune_slack : float, nats: at each search level, cells whose best score is below ``accept - prune_slack`` are dropped
        (2 and 4 gave identical estimates on every accuracy-benchmark scene; 2 is ~20% faster)
    max_hypotheses : int, cap on the (cell, radius) pairs scored at one level (memory bound)
    pose_sigma_mm : float, millimetres, stated 1-sigma error of each view's camera position per axis (0: exact)
    pose_sigma_deg : float, degrees, stated 1-sigma error of each view's camera rotation per axis (0: exact)
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
    pose_sigma_mm: float = 0.0
    pose_sigma_deg: float = 0.0

    def __post_init__(self) -> None:
        for name in ("n_radii", "lookahead", "min_views", "max_hypotheses"):
            v = getattr(self, name)
            if not (_is_real(v) and float(v).is_integer() and v >= 1):
                raise InputError(f"{name}: got {v!r}, expected an integer >= 1")
            object.__setattr__(self, name, int(v))
        for name in ("radius_min", "radius_max", "resolution", "coarse_resolution", "reach"):
            v = getattr(self, name)
            if not (_is_real(v) and np.isfinite(v) and v > 0):
                raise InputError(f"{name}: got {v!r}, expected a positive number of metres")
        if not self.radius_min < self.radius_max:
            raise InputError(f"radius_min/radius_max: got {self.radius_min}/{self.radius_max}, expected 0 < min < max (metres)")
        for name in ("pose_sigma_mm", "pose_sigma_deg", "prune_slack", "lookahead_margin"):
            v = getattr(self, name)
            if not (_is_real(v) and np.isfinite(v) and v >= 0):
                raise InputError(f"{name}: got {v!r}, expected a finite number >= 0")
        if not (_is_real(self.accept) and np.isfinite(self.accept)):
            raise InputError(f"accept: got {self.accept!r}, expected a finite number of nats")
        if self.min_views < 2:
            raise InputError(f"min_views: got {self.min_views}, expected >= 2 (one view cannot fix depth)")
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


@dataclass
class _ViewData:
    index: int
    view: View
    T_optical_base: NDArray[np.float64]
    boxes: NDArray[np.float64]
    contours: list[NDArray[np.float64] | None]
    available: NDArray[np.bool_]


class BayesLocalizer:
    """Stateful front end of the ``bayes`` method for incremental use.

    Call :meth:`update` as views arrive and :meth:`estimate` whenever
    estimates are needed (it re-runs the search and extraction over all views
    so far, which takes milliseconds to a fraction of a second).

    Parameters
    ----------
    camera : Camera
    config : BayesConfig
    workspace : Workspace, optional; else the paper's cube in front of the first view with a detection

    Attributes
    ----------
    pose_corrections : list of dict, the pose corrections of the last :meth:`estimate`
        (empty unless a pose uncertainty is configured; see :func:`localize_bayes`)
    """

    def __init__(self, camera: Camera, config: BayesConfig | None = None, *, workspace: Workspace | None = None) -> None:
        self.camera = camera
        self.config = config or BayesConfig()
        self.workspace = workspace
        self.views: list[View] = []
        self.grid: VoxelGrid | None = None
        self.timing_s: dict[str, float] = {}
        self.last_hypotheses: dict[str, Any] = {}
        self.pose_corrections: list[dict[str, Any]] = []

    def update(self, view: View) -> None:
        """Add one view."""
        self.views.append(view)
        if self.grid is None and view.detections:
            cfg = self.config
            if self.workspace is not None:
                self.grid = VoxelGrid.from_bounds(self.workspace.min, self.workspace.max, cfg.search_start)
            else:
                self.grid = VoxelGrid.in_front_of_camera(view.T_base_optical, cfg.search_start, cfg.reach)

    def _view_data(self) -> list[_ViewData]:
        out = []
        for i, v in enumerate(self.views):
            if not v.detections:
                continue
            contours: list[NDArray[np.float64] | None] = []
            for j, d in enumerate(v.detections):
                if self.config.use_masks and d.mask is not None:
                    try:
                        contours.append(contour_points(d.mask))
                    except InputError as exc:
                        raise InputError(f"views[{i}].detections[{j}].{exc}") from None
                else:
                    contours.append(None)
            out.append(
                _ViewData(i, v, invert_transform(v.T_base_optical), v.boxes_xyxy, contours, np.ones(len(v.detections), bool))
            )
        return out

    def estimate(self) -> list[DetectedObject]:
        """Objects found in the views so far (see the module docstring for the algorithm)."""
        cfg, cam, model = self.config, self.camera, self.config.sensor
        vds = self._view_data()
        if self.grid is None or len(vds) < cfg.min_views:
            return []
        t0 = time.perf_counter()
        radii = cfg.radii
        grid = self.grid
        R, t = grid.T_base_grid[:3, :3], grid.T_base_grid[:3, 3]
        centres_grid, cell = grid.centres_grid(), grid.resolution
        n_scored = 0
        floor = cfg.accept - cfg.prune_slack
        mask = np.ones((len(centres_grid), len(radii)), dtype=bool)
        while True:
            centres = centres_grid @ R.T + t
            if HAVE_NUMBA:
                counts = cone_counts_fused(
                    cam, [vd.T_optical_base for vd in vds], [vd.boxes for vd in vds], centres, cell * np.sqrt(3) / 2
                )
            else:
                counts = cone_counts(cam, [vd.view for vd in vds], centres, cell * np.sqrt(3) / 2)
            keep = counts >= cfg.min_views
            centres_grid, centres, mask = centres_grid[keep], centres[keep], mask[keep]
            n_alloc = len(centres) * len(radii)  # the arrays are (cells, radii) even where the mask skips radii
            if n_alloc > cfg.max_hypotheses:
                raise InputError(
                    f"resolution: {n_alloc:,} hypotheses exceed max_hypotheses={cfg.max_hypotheses:,}; "
                    "use a coarser --resolution, fewer radius bins or a smaller workspace"
                )
            n_scored += int(mask.sum())
            total, n_assoc, assoc = self._score(vds, centres, radii, cell, model, mask)
            # scores only fall as boxes are taken, so a hypothesis below the floor never matters again
            mask = (total >= floor) & (n_assoc >= cfg.min_views)
            good_cells = mask.any(axis=1)
            centres_grid, centres, mask = centres_grid[good_cells], centres[good_cells], mask[good_cells]
            total, n_assoc, assoc = total[good_cells], n_assoc[good_cells], assoc[:, good_cells]
            if cell <= cfg.resolution * (1 + 1e-9) or len(centres) == 0:
                break
            # children inherit the radii their parent kept, widened by one bin (the
            # parent's score is blurred in position, not in radius)
            for _ in range(_RADIUS_MARGIN_BINS):
                mask = mask | np.pad(mask[:, 1:], ((0, 0), (0, 1))) | np.pad(mask[:, :-1], ((0, 0), (1, 0)))
            mask = np.repeat(mask, 8, axis=0)  # split_cells puts cell i's children at rows 8i..8i+7
            centres_grid = split_cells(centres_grid, cell)
            cell /= 2
        t1 = time.perf_counter()
        # the grid scores with every box available, for the steal pass after the extraction
        initial = (total.copy(), n_assoc.copy(), assoc.copy())
        self.last_hypotheses = {"cell_size": cell, "n_scored": int(n_scored), "n_cells_kept": len(centres)}
        objects: list[DetectedObject] = []
        active = np.ones(total.shape, dtype=bool)
        max_iter = sum(len(vd.boxes) for vd in vds) * 3 + 10
        refined: dict[tuple[int, int], DetectedObject | None] = {}
        for _ in range(max_iter):
            scores = np.where(active & (n_assoc >= cfg.min_views), total, -np.inf)
            if scores.size == 0:
                break
            best_grid = float(scores.max())
            if not np.isfinite(best_grid) or best_grid < floor:
                break
            # look ahead: the grid score is blurred by the cell size, so refine the few distinct
            # candidates whose grid score is close to the best and take the best refined one
            candidates = []
            trial = active.copy()
            for _ in range(cfg.lookahead):
                sc = np.where(trial & (n_assoc >= cfg.min_views), total, -np.inf)
                c, k = np.unravel_index(int(np.argmax(sc)), sc.shape)
                if not np.isfinite(sc[c, k]) or sc[c, k] < max(floor, best_grid - cfg.lookahead_margin):
                    break
                key = (int(c), int(k))
                if key not in refined:  # a cached result stays valid while its boxes are available
                    _, assoc_h = self._score_one(vds, centres[c], float(radii[k]), model, cell)
                    refined[key] = self._refine_and_check(vds, centres[c], float(radii[k]), assoc_h, model)
                cand = refined[key]
                near = np.linalg.norm(centres - centres[c], axis=1) <= max(2 * cell, radii[k])
                trial[near] = False
                candidates.append((cand, near))
            for cand, near in candidates:
                if cand is None:
                    active[near] = False
            accepted = [cand for cand, _ in candidates if cand is not None]
            if not accepted:
                continue
            obj = max(accepted, key=lambda o: o.score)
            objects.append(obj)
            taken = {(vi, j) for vi, j in obj.associations.items()}
            refined = {
                key: o for key, o in refined.items() if o is not None and o is not obj and not taken & set(o.associations.items())
            }
            for vd in vds:
                j = obj.associations.get(vd.index)
                if j is not None:
                    vd.available[j] = False
            near = np.linalg.norm(centres - obj.position, axis=1) <= max(cell, 0.5 * float(obj.radius or 0))
            active[near] = False
            # only hypotheses that were using one of the boxes just explained change score
            affected = np.zeros(len(centres), dtype=bool)
            for v, vd in enumerate(vds):
                j = obj.associations.get(vd.index)
                if j is not None:
                    affected |= (assoc[v] == j).any(axis=1)
            if affected.any():
                sub = np.flatnonzero(affected)
                t_sub, n_sub, a_sub = self._score(vds, centres[sub], radii, cell, model, mask[sub])
                total[sub], n_assoc[sub], assoc[:, sub] = t_sub, n_sub, a_sub
        objects = self._swap_pass(vds, objects, model)
        objects = self._steal_pass(vds, objects, model, centres, radii, cell, initial)
        t2 = time.perf_counter()
        self.timing_s = {"search_score": t1 - t0, "extract_refine": t2 - t1}
        self.pose_corrections = []
        if cfg.poses_uncertain and objects:
            objects = self._bundle(vds, objects, model)
            self.timing_s["bundle"] = time.perf_counter() - t2
        objects.sort(key=lambda o: -o.score)
        return objects

    def _score(
        self,
        vds: list[_ViewData],
        centres: NDArray[np.float64],
        radii: NDArray[np.float64],
        cell: float,
        model: SensorModel,
        mask: NDArray[np.bool_],
    ) -> tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.int16]]:
        """Score the (cell, radius) hypotheses selected by ``mask`` (N, K) with the boxes still available.

        Returns the total score (N, K; -inf where not selected), the number of views with an associated
        box (N, K) and the associated box per view (V, N, K; -1 for none). The
        cell's projected half-diagonal is added to the edge noise, so a cell
        is scored as the region it stands for.
        """
        blur = cell * np.sqrt(3) / 2
        cfg = self.config
        if HAVE_NUMBA:
            # the pose's position uncertainty scales with 1/depth like the cell blur; its rotation part is constant
            return score_hypotheses(
                self.camera,
                [vd.T_optical_base for vd in vds],
                [vd.boxes for vd in vds],
                [vd.available for vd in vds],
                centres,
                radii,
                model,
                float(np.hypot(blur, cfg.pose_position_sigma)) if cfg.pose_position_sigma > 0 else blur,
                max(self.camera.fx, self.camera.fy) * cfg.pose_rotation_sigma,
                mask,
            )
        cam = self.camera
        total = np.zeros((len(centres), len(radii)))
        n_assoc = np.zeros((len(centres), len(radii)), dtype=np.int32)
        assoc = np.empty((len(vds), len(centres), len(radii)), dtype=np.int16)
        for v, vd in enumerate(vds):
            p_opt = transform_points(vd.T_optical_base, centres)
            pred, visible = predict_boxes(cam, p_opt, radii)
            extra = max(cam.fx, cam.fy) * blur / np.maximum(p_opt[:, 2:3], 1e-6)
            if cfg.poses_uncertain:
                extra = np.hypot(extra, self._pose_px(p_opt[:, 2:3]))
            llr, a = view_scores(pred, visible, vd.boxes, vd.available, model, cam.width, cam.height, extra)
            total += llr
            n_assoc += a >= 0
            assoc[v] = a
        total[~mask], n_assoc[~mask], assoc[:, ~mask] = -np.inf, 0, -1
        return total, n_assoc, assoc

    def _score_one(
        self, vds: list[_ViewData], centre: NDArray[np.float64], radius: float, model: SensorModel, cell: float = 0.0
    ) -> tuple[float, list[int]]:
        """Score (nats) and best available box per view (-1: none) of one sphere; ``cell`` > 0 blurs it as a grid cell."""
        total, _, assoc = self._score(vds, centre[None, :], np.array([radius]), cell, model, np.ones((1, 1), dtype=bool))
        return float(total[0, 0]), [int(a) for a in assoc[:, 0, 0]]

    def _pose_px(self, depth: NDArray[np.floating] | float) -> NDArray[np.float64] | float:
        """Edge noise (pixels) of the stated pose uncertainty at ``depth`` (metres); exactly 0.0 when poses are exact."""
        cfg = self.config
        if not cfg.poses_uncertain:
            return 0.0
        return pose_sigma_px(self.camera, depth, cfg.pose_position_sigma, cfg.pose_rotation_sigma)

    def _observations(self, vds: list[_ViewData], assoc: list[int], centre: NDArray[np.float64]) -> list[Observation]:
        """Observations of the associated boxes (-1: none), with the pose noise at ``centre``'s depth in each view."""
        use_masks = self.config.use_masks
        out = []
        for vd, j in zip(vds, assoc):
            if j < 0:
                continue
            depth = float(vd.T_optical_base[2, :3] @ centre + vd.T_optical_base[2, 3])
            out.append(
                Observation(vd.T_optical_base, vd.boxes[j], vd.contours[j] if use_masks else None, float(self._pose_px(depth)))
            )
        return out

    def _bundle(self, vds: list[_ViewData], objects: list[DetectedObject], model: SensorModel) -> list[DetectedObject]:
        """Refine all objects jointly with a pose correction per view (:mod:`.bundle`); sets ``pose_corrections``."""
        cfg = self.config
        obs = [
            (i, v, Observation(vd.T_optical_base, vd.boxes[j], vd.contours[j] if cfg.use_masks else None))
            for i, o in enumerate(objects)
            for v, vd in enumerate(vds)
            if (j := o.associations.get(vd.index, -1)) >= 0
        ]
        b = bundle_adjust(
            self.camera,
            obs,
            np.stack([o.position for o in objects]),
            np.array([float(o.radius) for o in objects]),
            model,
            position_sigma=cfg.pose_position_sigma,
            rotation_sigma=cfg.pose_rotation_sigma,
            use_masks=cfg.use_masks,
            n_views=len(vds),
        )
        out = []
        for i, o in enumerate(objects):
            if not (np.all(np.isfinite(b.centres[i])) and cfg.radius_min * 0.5 <= b.radii[i] <= cfg.radius_max * 2):
                out.append(o)  # keep the per-object solution rather than a diverged joint one
                continue
            extra = {**o.extra, "radius_std": float(b.radius_std[i]), "pose_corrected": True}
            out.append(
                DetectedObject(
                    position=b.centres[i],
                    score=o.score,
                    radius=float(b.radii[i]),
                    covariance=b.covariances[i],
                    associations=o.associations,
                    n_cells=o.n_cells,
                    extra=extra,
                )
            )
        for v, vd in enumerate(vds):
            T_corrected = correction_transform(b.rotvec_optical[v], b.translation_optical[v]) @ vd.T_optical_base
            self.pose_corrections.append(
                {
                    "view": vd.index,
                    "rotvec_optical_rad": b.rotvec_optical[v].tolist(),
                    "translation_optical_m": b.translation_optical[v].tolist(),
                    "std_rotvec_optical_rad": b.pose_std[v, :3].tolist(),
                    "std_translation_optical_m": b.pose_std[v, 3:].tolist(),
                    "T_base_optical_corrected": invert_transform(T_corrected).tolist(),
                }
            )
        return out

    def _refine_and_check(
        self, vds: list[_ViewData], centre0: NDArray[np.float64], radius0: float, assoc0: list[int], model: SensorModel
    ) -> DetectedObject | None:
        cfg, cam = self.config, self.camera
        assoc = assoc0
        centre, radius = centre0, float(radius0)
        refined = None
        for _ in range(3):
            obs = self._observations(vds, assoc, centre)
            if len(obs) < cfg.min_views:
                return None
            refined = refine_sphere(cam, obs, centre, radius, model, use_masks=cfg.use_masks)
            centre, radius = refined.centre, refined.radius
            if not (cfg.radius_min * 0.5 <= radius <= cfg.radius_max * 2):
                return None
            score, new_assoc = self._score_one(vds, centre, radius, model)
            if new_assoc == assoc:
                break
            assoc = new_assoc
        n_views = sum(a >= 0 for a in assoc)
        if refined is None or n_views < cfg.min_views or score < cfg.accept:
            return None
        return DetectedObject(
            position=centre,
            score=score,
            radius=radius,
            covariance=refined.covariance,
            associations={vd.index: a for vd, a in zip(vds, assoc) if a >= 0},
            extra={"radius_std": refined.radius_std, "n_views": int(n_views)},
        )

    def _fit_fixed(
        self, vds: list[_ViewData], centre0: NDArray[np.float64], radius0: float, assoc: list[int], model: SensorModel
    ) -> DetectedObject | None:
        """Refine one object with a fixed association and score it with that association."""
        cfg, cam = self.config, self.camera
        obs = self._observations(vds, assoc, centre0)
        if len(obs) < cfg.min_views:
            return None
        refined = refine_sphere(cam, obs, centre0, radius0, model, use_masks=cfg.use_masks)
        if not (cfg.radius_min * 0.5 <= refined.radius <= cfg.radius_max * 2):
            return None
        score = 0.0
        for vd, j in zip(vds, assoc):
            p_opt = vd.T_optical_base[:3, :3] @ refined.centre + vd.T_optical_base[:3, 3]
            pred, visible = predict_boxes(cam, p_opt[None, :], np.array([refined.radius]))
            if not visible[0, 0]:
                continue
            s = box_scores(pred[0, 0], vd.boxes[j], model, cam.width, cam.height, self._pose_px(p_opt[2])) if j >= 0 else -np.inf
            score += max(float(s), model.miss_term)
        return DetectedObject(
            position=refined.centre,
            score=score,
            radius=refined.radius,
            covariance=refined.covariance,
            associations={vd.index: a for vd, a in zip(vds, assoc) if a >= 0},
            extra={"radius_std": refined.radius_std, "n_views": len(obs)},
        )

    def _steal_pass(
        self,
        vds: list[_ViewData],
        objects: list[DetectedObject],
        model: SensorModel,
        centres: NDArray[np.float64],
        radii: NDArray[np.float64],
        cell: float,
        initial: tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.int16]],
    ) -> list[DetectedObject]:
        """Give a fruit back the box a neighbour took when the neighbour can do without it.

        The greedy extraction can give a fruit the box of a neighbour that lost
        its own box in that view (occluded or missed): the neighbour is then
        left with one view and never accepted. Candidates are grid hypotheses
        (scored with every box available, before extraction) that use at
        least one box nobody took and at least one box an accepted object
        holds. For the best few, the holders give up those boxes and are refit
        without them, the candidate is refined with the boxes left to it, and
        the move is kept when both stay acceptable and the summed score grows
        by more than ``accept`` (what a new object must earn in the extraction).
        """
        cfg = self.config
        total0, n0, assoc0 = initial
        if not objects or total0.size == 0:
            return objects
        holder: dict[tuple[int, int], int] = {}
        for i, o in enumerate(objects):
            for v, vd in enumerate(vds):
                j = o.associations.get(vd.index)
                if j is not None:
                    holder[(v, j)] = i
        # per view, a lookup over box index (+ one slot for -1): is the box free / held?
        free = [np.append(vd.available, False) for vd in vds]
        if not any(f.any() for f in free):
            return objects
        held = [np.append(~vd.available, False) for vd in vds]
        n_free = sum(f[a] for f, a in zip(free, assoc0))
        n_held = sum(h[a] for h, a in zip(held, assoc0))
        ok = (total0 >= cfg.accept - cfg.prune_slack) & (n0 >= cfg.min_views) & (n_free >= 1) & (n_held >= 1)
        tried = np.zeros(len(centres), dtype=bool)
        for _ in range(cfg.lookahead):
            sc = np.where(ok & ~tried[:, None], total0, -np.inf)
            if not np.isfinite(sc.max(initial=-np.inf)):
                break
            c, k = np.unravel_index(int(np.argmax(sc)), sc.shape)
            tried |= np.linalg.norm(centres - centres[c], axis=1) <= max(2 * cell, radii[k])
            wanted = [int(a) for a in assoc0[:, c, k]]
            stolen = [(v, j) for v, j in enumerate(wanted) if j >= 0 and (v, j) in holder]
            for v, j in stolen:
                vds[v].available[j] = True
            new = self._refine_and_check(vds, centres[c], float(radii[k]), wanted, model)
            losers: dict[int, DetectedObject | None] = {}
            if new is not None:
                taken = {(v, new.associations[vd.index]) for v, vd in enumerate(vds) if vd.index in new.associations}
                for i in sorted({holder[b] for b in taken if b in holder}):
                    o = objects[i]
                    keep = [-1 if (v, j) in taken else j for v, vd in enumerate(vds) for j in [o.associations.get(vd.index, -1)]]
                    refit = self._fit_fixed(vds, o.position, float(o.radius), keep, model)
                    losers[i] = refit if refit is not None and refit.score >= cfg.accept else None
            gain = (
                new.score + sum(o.score for o in losers.values() if o is not None) - sum(objects[i].score for i in losers)
                if new is not None and losers and all(o is not None for o in losers.values())
                else -np.inf
            )
            for v, j in stolen:
                vds[v].available[j] = False
            # a new object must pay for itself, as in the extraction: its score counts above ``accept``
            if gain <= cfg.accept or new is None:
                continue
            for i, o in losers.items():
                objects[i] = o  # type: ignore[assignment]
            objects.append(new)
            for v, vd in enumerate(vds):
                j = new.associations.get(vd.index)
                if j is not None:
                    vd.available[j] = False
                    holder[(v, j)] = len(objects) - 1
        return objects

    def _swap_pass(self, vds: list[_ViewData], objects: list[DetectedObject], model: SensorModel) -> list[DetectedObject]:
        """Fix greedy association mistakes between fruit that overlap in a view (one hiding the other).

        The greedy extraction can give a fruit the box of the fruit in front
        of it (that box matches its full silhouette better than its own,
        truncated box). For every view and every pair of objects whose
        predicted boxes overlap there, swap their boxes in that view, refit
        both, and keep the swap if their summed score grows by more than 1 nat.
        """
        cam = self.camera

        def predicted(vd: _ViewData, o: DetectedObject) -> NDArray[np.float64]:
            p_opt = vd.T_optical_base[:3, :3] @ o.position + vd.T_optical_base[:3, 3]
            return predict_boxes(cam, p_opt[None, :], np.array([o.radius]))[0][0, 0]

        for _ in range(2):
            changed = False
            for v, vd in enumerate(vds):
                holders = [i for i, o in enumerate(objects) if vd.index in o.associations]
                boxes = {i: predicted(vd, objects[i]) for i in holders}  # once per object, not per pair
                for ia, ib in combinations(holders, 2):
                    a, b = objects[ia], objects[ib]
                    (ax1, ay1, ax2, ay2), (bx1, by1, bx2, by2) = boxes[ia], boxes[ib]
                    if not (min(ax2, bx2) > max(ax1, bx1) and min(ay2, by2) > max(ay1, by1)):
                        continue
                    assoc_a = [a.associations.get(w.index, -1) for w in vds]
                    assoc_b = [b.associations.get(w.index, -1) for w in vds]
                    assoc_a[v], assoc_b[v] = assoc_b[v], assoc_a[v]
                    new_a = self._fit_fixed(vds, a.position, float(a.radius), assoc_a, model)
                    new_b = self._fit_fixed(vds, b.position, float(b.radius), assoc_b, model)
                    if new_a is None or new_b is None or new_a.score + new_b.score <= a.score + b.score + 1.0:
                        continue
                    objects[ia], objects[ib] = new_a, new_b
                    boxes[ia], boxes[ib] = predicted(vd, new_a), predicted(vd, new_b)
                    changed = True
            if not changed:
                break
        return objects


@register_method("bayes")
def localize_bayes(session: Session, *, progress: Callable[[int, int], None] | None = None, **options: Any) -> Result:
    """The ghost-free, size-aware method (see :class:`BayesConfig` for the options).

    With ``pose_sigma_mm`` or ``pose_sigma_deg`` > 0, ``Result.config["pose_corrections"]``
    lists, per view with detections, the estimated correction of its reported pose:
    ``view`` (index in the session), ``rotvec_optical_rad`` and ``translation_optical_m``
    (``p_optical_true = exp([rotvec]x) @ p_optical_reported + translation``, see
    :mod:`monovisual3d.bayes.bundle`), their posterior std ``std_rotvec_optical_rad`` and
    ``std_translation_optical_m``, and ``T_base_optical_corrected`` (4x4 nested lists).
    """
    known = {f.name for f in fields(BayesConfig)}
    unknown = sorted(set(options) - known)
    if unknown:
        raise InputError(f"{unknown[0]}: not an option of method 'bayes', expected one of {sorted(known)}")
    config = BayesConfig(**options)
    t0 = time.perf_counter()
    loc = BayesLocalizer(session.camera, config, workspace=session.workspace)
    for i, view in enumerate(session.views):
        loc.update(view)
        if progress is not None:
            progress(i + 1, len(session.views))
    n_with = sum(1 for v in session.views if v.detections)
    messages = []
    if n_with < config.min_views:
        msg = f"only {n_with} view(s) have detections; at least {config.min_views} are needed to localise anything"
        warnings.warn(InputWarning(msg), stacklevel=2)
        messages.append(msg)
    objects = loc.estimate()
    if n_with >= config.min_views and not objects:
        msg = (
            f"{n_with} views have detections but no object is consistent across them; check that positions are metres, "
            "quaternions are (x, y, z, w), pose_frame is right, and that the views look at the same fruit "
            f"(objects scoring below accept={config.accept:g} nats are not reported)"
        )
        warnings.warn(InputWarning(msg), stacklevel=2)
        messages.append(msg)
    t1 = time.perf_counter()
    grid = loc.grid.to_dict() if loc.grid is not None else {}
    grid.update(loc.last_hypotheses)
    return Result(
        objects=objects,
        method="bayes",
        grid=grid,
        timing_s={**loc.timing_s, "total": t1 - t0},
        config={**asdict(config), "pose_corrections": loc.pose_corrections} if config.poses_uncertain else asdict(config),
        warnings=messages,
    )
