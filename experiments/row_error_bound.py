"""Dense vs sparse plant rows: the ``bayes`` method's error per fruit against its Cramer-Rao bound.

Question (issue 22): is "a dense row as accurate as a sparse one (mean error within 1.2x)"
reachable by physics, and where does the method lose accuracy in dense rows?

For each row scene of :func:`monovisual3d.bench.scale.row_session` (same scene, camera, views,
noise and seed), per fruit, from what the simulator actually produced:

- the views whose boxes come from the fruit (the true association, ``SimulatedView.source``);
- each box edge classed as *full* (the visible box's edge lies within ``CUT_PX`` of the edge of the
  fruit's whole silhouette box), *border* (the silhouette box leaves the image on that side) or
  *occluded* (a nearer fruit cuts the visible box on that side);
- the Cramer-Rao bound on the centre with the fruit's centre and radius unknown: Fisher information
  ``sum J^T C^-1 J`` over the *full* edges only (a cut edge says where the occluder or the border is,
  not where the fruit is), ``J`` the derivative of the silhouette box's edges, ``C`` the simulator's
  edge covariance (:func:`monovisual3d.geometry.bounds.box_edge_covariance`) with the size of the box
  the simulator perturbed (the visible, cut, box: its noise scales with it).

Reported per fruit count (all seeds pooled, matched fruit only): the method's mean Euclidean error,
the bound as the mean Euclidean norm of a Gaussian with the bound's covariance (what an efficient
unbiased estimator would score, comparable to a mean error), the RMS error and RMS bound, the
efficiency (mean error / mean bound), the bound again with the noise of the whole (uncut) box (a
detector whose noise does not shrink with an occluded box: ``bound uncut-noise``), the same split by fruit with and without occluded edges, and
the mean error and mean bound over those of the first (sparsest) fruit count (``error / sparse``,
``bound / sparse``: the issue's target is an error ratio of at most 1.2 at 96 fruit against 12).
Two oracle estimators with the true association isolate the refinement from the association:
``oracle`` is the method's own robust refinement (:func:`monovisual3d.methods.bayes.refine.refine_sphere`)
on the true boxes, started at the truth; ``oracle-censored`` the same with the occluded edges censored
(only outward residuals count, as the method already does at the image border).

Run: ``python experiments/row_error_bound.py [--fruit 12 24 48 96] [--seeds 0 1 2 100 101 102 103 104]``
(about 10 minutes of CPU with the defaults); ``--no-refit`` runs the method without the shape stage's
occlusion refit (:func:`monovisual3d.methods.bayes.shapes.occlusion_refit`), as it was before it.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from monovisual3d.api import localize
from monovisual3d.bench.scale import BOX_NOISE, OPTIONS, row_session
from monovisual3d.frames import invert_transform
from monovisual3d.geometry.bounds import box_edge_covariance
from monovisual3d.geometry.levenberg import levenberg_marquardt
from monovisual3d.geometry.sphere import predict_sphere_boxes
from monovisual3d.methods.bayes import shapes
from monovisual3d.methods.bayes.refine import MAX_NFEV, SPHERE_X_SCALE, Observation, _SphereResiduals, refine_sphere, robust_loss
from monovisual3d.methods.bayes.sensor import SensorModel
from monovisual3d.metrics import match
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.row import row_camera
from monovisual3d.sim.simulate import simulate_views
from monovisual3d.sim.viewpoints import row_poses

#: A visible edge more than this many pixels inside the whole silhouette box is cut (pixel quantisation is < 1 px).
CUT_PX = 1.5
#: An edge of the silhouette box within this many pixels of the image border (or beyond) is clipped.
BORDER_PX = 0.5
#: Finite-difference step (metres) of the box Jacobian.
STEP_M = 1e-6
#: Gaussian samples per fruit for the mean Euclidean norm of the bound.
NORM_SAMPLES = 4000
N_VIEWS = 5


@dataclass
class FruitRow:
    n_views: int
    n_occluded: int
    n_border: int
    bound_sq: float  # trace of the centre bound, m^2 (inf: singular)
    bound_norm: float  # mean Euclidean norm of N(0, bound), m
    bound_norm_full: float  # the same with the noise of the whole (uncut) box, m
    error: float | None = None  # method, m (None: missed)
    wrong_boxes: int = 0
    missing_boxes: int = 0
    oracle: float | None = None
    oracle_censored: float | None = None


def sphere_box(camera, T_base_optical, centre, radius):  # noqa: ANN001, ANN201
    T_ob = invert_transform(T_base_optical)
    p = T_ob[:3, :3] @ centre + T_ob[:3, 3]
    return predict_sphere_boxes(camera, p[None], np.array([radius]))[0][0, 0]


def fruit_bound(camera, views, f, centre, radius, rng):  # noqa: ANN001, ANN201
    """Bound, edge classes and the observations (true boxes) of fruit ``f``."""
    size = np.array([camera.width, camera.height] * 2, dtype=float)
    F, F_full = np.zeros((4, 4)), np.zeros((4, 4))
    n_views = n_occ = n_border = 0
    obs, obs_cens = [], []
    for sv in views:
        k = np.flatnonzero(sv.source == f)
        if not len(k):
            continue
        n_views += 1
        full = sphere_box(camera, sv.T_base_optical_true, centre, radius)
        vis = sv.rendering.boxes_xyxy[f]
        border = np.array(
            [full[0] < BORDER_PX, full[1] < BORDER_PX, full[2] > size[2] - BORDER_PX, full[3] > size[3] - BORDER_PX]
        )
        inward = np.array([vis[0] - full[0], vis[1] - full[1], full[2] - vis[2], full[3] - vis[3]])
        occluded = ~border & (inward > CUT_PX)
        n_occ += int(occluded.sum())
        n_border += int(border.sum())
        usable = ~border & ~occluded
        J = np.stack(
            [
                (
                    sphere_box(camera, sv.T_base_optical_true, centre + h[:3], radius + h[3])
                    - sphere_box(camera, sv.T_base_optical_true, centre - h[:3], radius - h[3])
                )
                / (2 * STEP_M)
                for h in np.eye(4) * STEP_M
            ],
            axis=1,
        )
        C = box_edge_covariance(vis, BOX_NOISE)
        C_full = box_edge_covariance(np.clip(full, 0.0, size), BOX_NOISE)  # a detector whose noise ignores the cut
        idx = np.flatnonzero(usable)
        if len(idx):
            F += J[idx].T @ np.linalg.solve(C[np.ix_(idx, idx)], J[idx])
            F_full += J[idx].T @ np.linalg.solve(C_full[np.ix_(idx, idx)], J[idx])
        T_ob = invert_transform(sv.T_base_optical_reported)
        box = sv.boxes_xyxy[k[0]]
        obs.append(Observation(T_ob, box))
        obs_cens.append(occluded)
    bound_sq, bound_norm = centre_bound(F, rng)
    bound_norm_full = centre_bound(F_full, rng)[1]
    return FruitRow(n_views, n_occ, n_border, bound_sq, bound_norm, bound_norm_full), obs, obs_cens


def centre_bound(F: np.ndarray, rng: np.random.Generator) -> tuple[float, float]:
    """Trace of the centre's bound (m^2) and the mean Euclidean norm of a Gaussian with it (m); inf when singular."""
    if not np.any(F) or np.linalg.matrix_rank(F, tol=1e-9 * np.abs(F).max()) < 4:
        return np.inf, np.inf
    cov = np.linalg.inv(F)[:3, :3]
    L = np.linalg.cholesky(cov + 1e-18 * np.eye(3))
    return float(np.trace(cov)), float(np.mean(np.linalg.norm(rng.standard_normal((NORM_SAMPLES, 3)) @ L.T, axis=1)))


def refine_censored(camera, obs, occluded, centre, radius, model):  # noqa: ANN001, ANN201
    """:func:`refine_sphere` with the occluded edges censored as the method censors the image border's (outward only)."""
    fun = _SphereResiduals(camera, obs, model, use_masks=False)
    fun.boxes.censored = fun.boxes.censored | occluded
    x0 = np.r_[centre, np.log(radius)]
    sol = levenberg_marquardt(fun.params_batch, x0, SPHERE_X_SCALE, loss=robust_loss(model.inward_floor), max_nfev=MAX_NFEV)
    return sol.x[:3]


def analyse_scene(n_fruit: int, seed: int) -> list[FruitRow]:
    session, scene = row_session(n_fruit, N_VIEWS, seed)
    camera = row_camera()
    views = simulate_views(scene, camera, row_poses(N_VIEWS), noise=NoiseModel(box_sigma=BOX_NOISE), rng=seed)
    for sv, v in zip(views, session.views):  # the same draws as the session the method sees
        assert np.allclose(sv.boxes_xyxy, [d.bbox_xyxy for d in v.detections])
    rng = np.random.default_rng(seed)
    model = SensorModel()
    rows = []
    for f, (c, r) in enumerate(zip(scene.centres, scene.radii)):
        row, obs, obs_cens = fruit_bound(camera, views, f, c, r, rng)
        if len(obs) >= 2:
            row.oracle = float(np.linalg.norm(refine_sphere(camera, obs, c, r, model, use_masks=False).centre - c))
            row.oracle_censored = float(np.linalg.norm(refine_censored(camera, obs, np.array(obs_cens), c, r, model) - c))
        rows.append(row)
    res = localize(session, **OPTIONS)
    est = np.array([o.position for o in res.objects]).reshape(-1, 3)
    ei, ti = match(est, scene.centres)
    for e, t in zip(ei, ti):
        d = float(np.linalg.norm(est[e] - scene.centres[t]))
        if d > max(scene.radii[t], 0.01):  # evaluate's gate: the fruit's radius
            continue
        row = rows[t]
        row.error = d
        assoc = res.objects[e].associations
        row.wrong_boxes = sum(int(views[v].source[k] != t) for v, k in assoc.items())
        seen = {v for v, sv in enumerate(views) if np.any(sv.source == t)}
        row.missing_boxes = len(seen - {v for v, k in assoc.items() if views[v].source[k] == t})
    return rows


def summary(rows: list[FruitRow]) -> dict[str, float]:
    ok = [r for r in rows if r.error is not None and np.isfinite(r.bound_sq)]
    if not ok:
        return {"n": 0}
    err = np.array([r.error for r in ok])
    bnorm = np.array([r.bound_norm for r in ok])
    bfull = np.array([r.bound_norm_full for r in ok])
    bsq = np.array([r.bound_sq for r in ok])
    orc = np.array([r.oracle for r in ok if r.oracle is not None])
    orc_c = np.array([r.oracle_censored for r in ok if r.oracle_censored is not None])
    return {
        "n": len(ok),
        "mean_mm": 1e3 * err.mean(),
        "bound_mm": 1e3 * bnorm.mean(),
        "bound_full_mm": 1e3 * bfull.mean(),
        "rms_mm": 1e3 * np.sqrt(np.mean(err**2)),
        "rms_bound_mm": 1e3 * np.sqrt(bsq.mean()),
        "eff": err.mean() / bnorm.mean(),
        "oracle_mm": 1e3 * orc.mean() if len(orc) else np.nan,
        "oracle_cens_mm": 1e3 * orc_c.mean() if len(orc_c) else np.nan,
    }


HEADER = (
    "fruit",
    "seeds",
    "matched",
    "singular",
    "mean mm",
    "bound mm",
    "error / sparse",
    "bound / sparse",
    "eff",
    "bound uncut-noise mm",
    "its / sparse",
    "RMS mm",
    "RMS bound mm",
    "oracle mm",
    "oracle-cens mm",
    "occl. fruit %",
    "occl. eff",
    "clear eff",
    "wrong-assoc %",
    "views/fruit",
)


def table_row(n: int, n_seeds: int, rows: list[FruitRow], sparse: dict[str, float]) -> str:
    """One Markdown row of :data:`HEADER`; ``sparse`` is the :func:`summary` of the first (sparsest) fruit count."""
    s = summary(rows)
    occ = [r for r in rows if r.n_occluded]
    so, sc = summary(occ), summary([r for r in rows if not r.n_occluded])
    matched = [r for r in rows if r.error is not None]
    wrong = np.mean([r.wrong_boxes > 0 for r in matched]) if matched else np.nan
    singular = sum(not np.isfinite(r.bound_sq) for r in rows)
    return (
        f"| {n} | {n_seeds} | {len(matched)}/{len(rows)} | {singular} | {s['mean_mm']:.2f} | {s['bound_mm']:.2f} | "
        f"{s['mean_mm'] / sparse['mean_mm']:.2f} | {s['bound_mm'] / sparse['bound_mm']:.2f} | "
        f"{s['eff']:.2f} | {s['bound_full_mm']:.2f} | {s['bound_full_mm'] / sparse['bound_full_mm']:.2f} | {s['rms_mm']:.2f} | {s['rms_bound_mm']:.2f} | {s['oracle_mm']:.2f} | {s['oracle_cens_mm']:.2f} | "
        f"{100 * len(occ) / len(rows):.0f} | {so.get('eff', np.nan):.2f} | {sc.get('eff', np.nan):.2f} | "
        f"{100 * wrong:.1f} | {np.mean([r.n_views for r in rows]):.2f} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fruit", type=int, nargs="+", default=[12, 24, 48, 96])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 100, 101, 102, 103, 104])
    ap.add_argument(
        "--no-refit", action="store_true", help="without the occlusion refit of the shape stage (the method before it)"
    )
    a = ap.parse_args()
    if a.no_refit:
        shapes.occlusion_refit = lambda problem, objects: objects
    print("| " + " | ".join(HEADER) + " |\n|" + "---:|" * len(HEADER))
    first: dict[str, float] | None = None
    for n in a.fruit:
        rows = [r for s in a.seeds for r in analyse_scene(n, s)]
        first = first or summary(rows)
        print(table_row(n, len(a.seeds), rows, first), flush=True)


if __name__ == "__main__":
    main()
