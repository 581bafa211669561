"""Leaf occlusion: how close to the known-cut bound an estimator can come when it is told everything but the cuts.

The ``greenhouse-noise`` row's bound (:func:`monovisual3d.bench.accuracy.cut_crlb_rms_sq`) is told which box edges
leaves cut. ``experiments/unknown_cut_bound.py`` shows that not being told costs only about 3 % of Fisher information; but the
Fisher information is local, and the fruit that keep the default method above the bound are fruit whose boxes, cut
a few noise scales deep on several edges, are explained better by a sphere 10-40 mm away than by the true one (the
threshold effect, which no local bound sees; the script prints such fruit). It measures what the best estimator does
on those very boxes.

Per fruit it is told the true association (the boxes the simulator gave that fruit) and the statistics of the
simulator, not which edges are cut. Its likelihood is the simulator's box noise (an axis's two edges with the
centre-and-size covariance of :data:`monovisual3d.bench.leaf_cuts.PAIR_COVARIANCE`, scaled by the observed box) convolved with an
independent inward cut of each edge: with probability ``p_cut`` a depth with density ``s / (s + d)^2`` (noise-scale
units, one noise scale being ``box_sigma`` times the box's size; Lomax: median ``s``), both fitted to the cut depths
of calibration seeds. Its prior is flat in the centre and uniform over the simulator's fruit radii. It reports

- the posterior mean (the estimator of least mean squared error under this model), by importance sampling over a
  mixture of Student t densities at the posterior's modes;
- the posterior mode (MAP: what a robust least-squares fit is);
- the default method's final sphere fit on the same boxes (``shapes.one_sided_refit``'s loss, the association
  given, started from the truth),

each as its RMS centre error over the benchmark's RMS bound, as the accuracy benchmark computes its ratio, per seed set
and pooled (sums of squared errors over sums of squared bounds), and for the fruit whose default fit lies farthest
above its bound, the default's loss and the log posterior at the truth and at their optimum. The modes are searched
from the truth, from that fit and from points 15 and 30 mm nearer and farther than the fit along the mean viewing
direction: a numerical device only (the posterior mean does not depend on where its modes were found).

The model is not the simulator exactly (leaves cut neighbouring edges together, and the same side of a fruit in
nearby views; fruit that other detected fruit hide are cuts to it), so the posterior mean here is not a lower bound on
every estimator; it is the best this much knowledge of the simulator buys, association included. Results, on four
seed sets: ``docs/accuracy.md``.

Usage: python experiments/unknown_cut_mmse.py [CONDITION CAL_FIRST CAL_LAST FIRST:LAST [FIRST:LAST ...]] [--flat-radius]
(default greenhouse-noise 2000 2040 0:20: the cut statistics from seeds 2000-2039, the fruit of seeds 0-19;
``--flat-radius``: no radius prior, as the default method knows none)
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize
from scipy.signal import fftconvolve
from scipy.stats import multivariate_t

from monovisual3d.bench.accuracy import conditions
from monovisual3d.bench.leaf_cuts import FruitBoxes, edge_noise_density, fruit_boxes, pair_noise_density
from monovisual3d.camera import Camera
from monovisual3d.frames import invert_transform
from monovisual3d.geometry.bounds import BORDER_PX
from monovisual3d.geometry.sphere import pinhole_sphere_boxes
from monovisual3d.methods.bayes.config import BayesTuning
from monovisual3d.methods.bayes.refine import Observation, one_sided_residuals, refine_sphere, residuals
from monovisual3d.methods.bayes.sensor import SensorModel, censored_edges
from monovisual3d.sim.scenes import GREENHOUSE_RADIUS_RANGE, default_camera

#: Grid step of the density tables and the noise's half-width on them, noise-scale units.
STEP, NOISE_PAD = 0.1, 8.0
#: Cut depths the tables hold (noise-scale units); a deeper cut's density is taken analytically (a sliver of a fruit
#: behind a leaf is hundreds of its own noise scales deep).
TABLE_CUT = 100.0
#: Importance samples per mixture component, the Student t's degrees of freedom and the Laplace covariance's inflation.
N_SAMPLES, T_DOF, INFLATE = 20_000, 4.0, 2.0
#: Offsets (metres) along the mean viewing direction of the mode searches' starts besides the truth.
DEPTH_STARTS_M = (-0.03, -0.015, 0.015, 0.03)
#: Two modes closer than this (metres) are one.
SAME_MODE_M = 1e-3
#: Fruit shown per seed set: those whose default fit lies farthest above their bound.
WORST_SHOWN = 3


@dataclass(frozen=True)
class CutModel:
    """Each edge cut inward independently with probability ``p_cut``, by a depth of density ``s / (s + d)^2``
    (noise-scale units)."""

    p_cut: float
    s: float

    @classmethod
    def fit(cls, depths: np.ndarray) -> CutModel:
        """Cut rate and median cut depth of ``depths`` (0: uncut)."""
        return cls(float(np.mean(depths > 0)), float(np.median(depths[depths > 0])))

    def log_deep(self, d: np.ndarray) -> np.ndarray:
        """Log density of a cut this deep (beyond the tables, where the noise no longer matters)."""
        return np.log(self.p_cut * self.s) - 2 * np.log(self.s + np.maximum(d, 0.0))


class EdgeDensity:
    """Log densities of an axis's two edges' offsets from the silhouette box (noise-scale units, image coordinates: a
    cut moves the first edge +, the second -) and of one edge alone (inward +)."""

    def __init__(self, model: CutModel) -> None:
        self.model = model
        d = STEP * np.arange(int(TABLE_CUT / STEP) + 1)
        g = np.where(d > 0, model.p_cut * model.s / (model.s + d) ** 2 * STEP, 1.0 - model.p_cut)
        ax, _, noise = pair_noise_density(STEP, NOISE_PAD)
        pair = fftconvolve(np.outer(g, g[::-1]), noise)
        self.pair = np.log(np.maximum(pair, 1e-300))
        self.first0, self.second0 = -NOISE_PAD, -(TABLE_CUT + NOISE_PAD)
        self.single = np.log(np.maximum(np.convolve(g, edge_noise_density(ax)), 1e-300))
        self.deep = TABLE_CUT - NOISE_PAD  # beyond this an offset is a deep cut (the tables hold its whole noise below)

    def alone(self, u: np.ndarray) -> np.ndarray:
        """Log density of one edge's inward offset ``u`` (linear between the table's points)."""
        grid = -NOISE_PAD + STEP * np.arange(len(self.single))
        return np.where(u > self.deep, self.model.log_deep(u), np.interp(u, grid, self.single))

    def both(self, u1: np.ndarray, u2: np.ndarray) -> np.ndarray:
        """Log density of the two edges' offsets ``u1`` (first edge) and ``u2`` (second), bilinear between the table's
        points."""
        fi = np.clip((u1 - self.first0) / STEP, 0, self.pair.shape[0] - 1.001)
        fj = np.clip((u2 - self.second0) / STEP, 0, self.pair.shape[1] - 1.001)
        i, j = fi.astype(int), fj.astype(int)
        a, b = fi - i, fj - j
        table = (1 - a) * ((1 - b) * self.pair[i, j] + b * self.pair[i, j + 1]) + a * (
            (1 - b) * self.pair[i + 1, j] + b * self.pair[i + 1, j + 1]
        )
        deep1, deep2 = u1 > self.deep, -u2 > self.deep
        return np.where(
            deep1 & deep2,
            self.model.log_deep(u1) + self.model.log_deep(-u2),
            np.where(
                deep1,
                self.model.log_deep(u1) + self.alone(-u2),
                np.where(deep2, self.model.log_deep(-u2) + self.alone(u1), table),
            ),
        )


class FruitPosterior:
    """Log posterior of a sphere ``(x, y, z, r)`` (base frame, metres) given one fruit's boxes: flat in the centre,
    the radius uniform over ``radius_range`` (default the simulator's :data:`~monovisual3d.sim.scenes.GREENHOUSE_RADIUS_RANGE`;
    None: flat, as the default method knows no more).

    The prediction is clipped to the image, as the simulator clips a fruit's visible box before its noise; an observed
    edge on the image border (clipped again after the noise) is left out."""

    def __init__(
        self,
        camera: Camera,
        fruit: FruitBoxes,
        density: EdgeDensity,
        box_sigma: float,
        radius_range: tuple[float, float] | None = GREENHOUSE_RADIUS_RANGE,
    ) -> None:
        self.radius_range = radius_range
        T = np.array([invert_transform(T_bo) for T_bo in fruit.T_base_optical])
        self.R, self.t, self.camera, self.density = T[:, :3, :3], T[:, :3, 3], camera, density
        self.boxes = fruit.boxes
        self.on_border = censored_edges(fruit.boxes, camera.width, camera.height, BORDER_PX)
        self.scale = box_sigma * np.concatenate([fruit.boxes[:, 2:] - fruit.boxes[:, :2]] * 2, axis=1)

    def __call__(self, P: np.ndarray) -> np.ndarray:
        """Log posterior (N,) of parameter rows ``P`` (N, 4), up to a constant."""
        P = np.atleast_2d(P)
        if self.radius_range is None:
            return self.log_likelihood(P)
        r_min, r_max = self.radius_range
        return np.where((P[:, 3] >= r_min) & (P[:, 3] <= r_max), self.log_likelihood(P), -np.inf)

    def log_likelihood(self, P: np.ndarray) -> np.ndarray:
        """Log likelihood (N,) of parameter rows ``P`` (N, 4), up to a constant (-inf for a sphere behind a camera)."""
        P = np.atleast_2d(P)
        p_optical = np.einsum("mij,pj->pmi", self.R, P[:, :3]) + self.t
        with np.errstate(invalid="ignore", divide="ignore"):
            pred = pinhole_sphere_boxes(self.camera, p_optical, P[:, 3:4])
        pred = np.clip(pred, 0.0, np.array([self.camera.width, self.camera.height] * 2, dtype=float))
        u = (self.boxes - pred) / self.scale
        impossible = ~np.all(np.isfinite(u), axis=(1, 2))  # a sphere reaching behind a camera
        u = np.where(np.isfinite(u), u, 0.0)
        out = np.zeros(len(P))
        for i, k in ((0, 2), (1, 3)):
            border_i, border_k = self.on_border[:, i], self.on_border[:, k]
            term = np.where(
                border_i & border_k,
                0.0,
                np.where(
                    border_k,
                    self.density.alone(u[..., i]),
                    np.where(border_i, self.density.alone(-u[..., k]), self.density.both(u[..., i], u[..., k])),
                ),
            ) - np.where(border_i & border_k, 0.0, np.log(self.scale[:, i]) * np.where(border_i | border_k, 1, 2))
            out += term.sum(axis=1)
        return np.where((P[:, 3] > 0) & ~impossible, out, -np.inf)


def _mode(post: FruitPosterior, start: np.ndarray) -> tuple[np.ndarray, float]:
    """A local maximum of ``post`` from ``start`` and its log posterior."""
    simplex = start + np.vstack([np.zeros(4), np.eye(4) * 0.003])
    with np.errstate(invalid="ignore"):  # a simplex with corners outside the prior (-inf)
        res = minimize(
            lambda x: -float(post(x)[0]),
            start,
            method="Nelder-Mead",
            options={"xatol": 1e-5, "fatol": 1e-4, "maxiter": 4000, "initial_simplex": simplex},
        )
    return res.x, -float(res.fun)


def _laplace(post: FruitPosterior, x: np.ndarray, h: float = 1e-3) -> np.ndarray:
    """The posterior's covariance at the mode ``x`` (Laplace: the likelihood's curvature over ``h`` metres; the radius
    prior's bounds left out), its standard deviations clipped to 0.5-30 mm (a direction of no or negative curvature gets
    the widest)."""
    E = np.eye(len(x)) * h
    pp, pm = E[:, None] + E[None], E[:, None] - E[None]  # (n, n, 4): the four corners of each pair, in one call
    f = post.log_likelihood((x + np.stack([pp, pm, -pm, -pp], axis=2)).reshape(-1, len(x))).reshape(len(x), len(x), 4)
    H = (f[..., 0] - f[..., 1] - f[..., 2] + f[..., 3]) / (4 * h * h)
    if not np.all(np.isfinite(H)):
        return np.diag(np.full(len(x), 0.03**2))
    curvature, V = np.linalg.eigh(-(H + H.T) / 2)
    variance = np.where(curvature > 0, 1.0 / np.maximum(curvature, 1e-300), np.inf)
    return V @ np.diag(np.clip(variance, 5e-4**2, 0.03**2)) @ V.T


def posterior_mean(
    post: FruitPosterior, starts: list[np.ndarray], rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, float]:
    """The posterior mean, the highest mode and the effective sample size of the importance weights."""
    modes = sorted((_mode(post, s) for s in starts), key=lambda m: -m[1])
    comps: list[tuple[np.ndarray, np.ndarray]] = []
    for x, _ in modes:
        if all(np.linalg.norm(x[:3] - y[:3]) >= SAME_MODE_M for y, _ in comps):
            comps.append((x, INFLATE**2 * _laplace(post, x)))
    S = np.concatenate(
        [multivariate_t(loc=x, shape=C, df=T_DOF).rvs(N_SAMPLES, random_state=rng).reshape(-1, 4) for x, C in comps]
    )
    log_q = np.logaddexp.reduce([multivariate_t(loc=x, shape=C, df=T_DOF).logpdf(S) for x, C in comps], axis=0)
    log_w = post(S) - log_q
    w = np.exp(log_w - log_w[np.isfinite(log_w)].max())
    w[~np.isfinite(w)] = 0.0
    return (w[:, None] * S).sum(axis=0) / w.sum(), modes[0][0], float(w.sum() ** 2 / (w**2).sum())


def default_fit(camera: Camera, fruit: FruitBoxes, truth: np.ndarray) -> tuple[np.ndarray, float, float]:
    """``(x, y, z, r)`` of the default method's final sphere fit (:func:`monovisual3d.methods.bayes.shapes.one_sided_refit`'s
    loss) on the fruit's boxes, from ``truth``, and that loss (nats) at the fit and at the truth."""
    obs = [Observation(invert_transform(T_bo), box) for T_bo, box in zip(fruit.T_base_optical, fruit.boxes)]
    sensor = SensorModel()
    floors = (BayesTuning.cut_inward_floor, sensor.outward_floor)
    fit = refine_sphere(camera, obs, truth[:3], float(truth[3]), sensor, use_masks=False, floors=floors)
    at_truth = one_sided_residuals(residuals(np.append(truth[:3], np.log(truth[3])), camera, obs, sensor, False), *floors)
    return np.append(fit.centre, fit.radius), fit.cost, 0.5 * float(np.sum(at_truth**2))


def fruit_row(
    camera: Camera, fruit: FruitBoxes, density: EdgeDensity, sigma: float, rng: np.random.Generator, radius_prior: bool
) -> dict[str, Any]:
    """One fruit's squared errors (m^2) of the posterior mean, the posterior mode and the default's fit, its bound, the
    effective sample size, and what the two objectives say of the truth against their optimum."""
    post = FruitPosterior(camera, fruit, density, sigma, GREENHOUSE_RADIUS_RANGE if radius_prior else None)
    truth = np.append(fruit.ellipsoid.centre_base, fruit.radius)
    look = fruit.T_base_optical[:, :3, 2].mean(axis=0)
    look /= np.linalg.norm(look)
    dist = np.linalg.norm(fruit.T_base_optical[:, :3, 3] - truth[:3], axis=1).mean()
    fit, cost_fit, cost_truth = default_fit(camera, fruit, truth)
    starts = [truth, fit] + [fit + np.append(look * dz, fit[3] * dz / dist) for dz in DEPTH_STARTS_M]
    mean, mode, ess = posterior_mean(post, starts, rng)
    e_mean, e_mode, e_fit = (float(np.sum((x[:3] - truth[:3]) ** 2)) for x in (mean, mode, fit))
    return {
        "fruit": (fruit.seed, fruit.index, len(fruit.boxes)),
        "mean": e_mean,
        "mode": e_mode,
        "fit": e_fit,
        "bound": fruit.known_sq,
        "ess": ess,
        "loss": (cost_truth, cost_fit),
        "log_posterior": (float(post(truth)[0]), float(post(mode)[0])),
    }


def _ratio(rows: list[dict[str, Any]], key: str) -> float:
    return float(np.sqrt(sum(r[key] for r in rows) / sum(r["bound"] for r in rows)))


def report(label: str, rows: list[dict[str, Any]]) -> None:
    """Print the ratios of ``rows`` and the fruit whose default fit is farthest above its bound."""
    ess = np.array([r["ess"] for r in rows])
    print(
        f"{label}, {len(rows)} fruit: RMS over the known-cut bound ({1e3 * np.sqrt(np.mean([r['bound'] for r in rows])):.2f} mm): "
        f"posterior mean {_ratio(rows, 'mean'):.3f}, posterior mode {_ratio(rows, 'mode'):.3f}, the default's final loss "
        f"fitted from the truth {_ratio(rows, 'fit'):.3f} (effective samples median {np.median(ess):.0f}, least {ess.min():.0f})"
    )
    for r in sorted(rows, key=lambda r: r["bound"] - r["fit"])[:WORST_SHOWN]:
        seed, index, views = r["fruit"]
        print(
            f"  seed {seed} fruit {index} ({views} views): error mean / mode / fit "
            f"{1e3 * np.sqrt(r['mean']):.1f} / {1e3 * np.sqrt(r['mode']):.1f} / {1e3 * np.sqrt(r['fit']):.1f} mm, bound "
            f"{1e3 * np.sqrt(r['bound']):.1f} mm; the default's loss at the truth {r['loss'][0]:.1f} nats, at its fit "
            f"{r['loss'][1]:.1f}; log posterior at the truth {r['log_posterior'][0]:.1f}, at the mode {r['log_posterior'][1]:.1f}"
        )


def main(name: str, calibration: range, seed_sets: list[range], radius_prior: bool = True) -> None:
    cond = next(c for c in conditions(False) if c.name == name)
    camera, sigma = default_camera(), cond.noise.box_sigma
    model = CutModel.fit(np.concatenate([b.depths for b in fruit_boxes(name, calibration)]))
    density = EdgeDensity(model)
    rng = np.random.default_rng(0)
    print(
        f"{name}: cut model from seeds {calibration.start}-{calibration.stop - 1}: p_cut {model.p_cut:.3f}, "
        f"median depth {model.s:.1f} noise scales; radius prior {GREENHOUSE_RADIUS_RANGE if radius_prior else 'flat'}"
    )
    pooled = []
    for seeds in seed_sets:
        rows = [
            fruit_row(camera, f, density, sigma, rng, radius_prior) for f in fruit_boxes(name, seeds) if np.isfinite(f.known_sq)
        ]
        report(f"seeds {seeds.start}-{seeds.stop - 1}", rows)
        pooled += rows
    if len(seed_sets) > 1:
        report("pooled", pooled)


def _seed_range(text: str) -> range:
    """``FIRST:LAST`` as a range (LAST excluded)."""
    try:
        first, last = (int(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"got {text!r}, expected FIRST:LAST") from None
    return range(first, last)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("condition", nargs="?", default="greenhouse-noise", help="a bench accuracy condition (greenhouse-noise)")
    parser.add_argument("cal_first", nargs="?", type=int, default=2000, help="first calibration seed (default 2000)")
    parser.add_argument("cal_last", nargs="?", type=int, default=2040, help="last calibration seed, excluded (default 2040)")
    parser.add_argument("seed_sets", nargs="*", type=_seed_range, help="FIRST:LAST seed sets (default 0:20)")
    parser.add_argument("--flat-radius", action="store_true", help="no radius prior, as the default method knows none")
    args = parser.parse_intermixed_args()
    if args.condition not in [c.name for c in conditions(False)]:
        parser.error(f"condition: got {args.condition!r}, expected one of {[c.name for c in conditions(False)]}")
    main(args.condition, range(args.cal_first, args.cal_last), args.seed_sets or [range(0, 20)], not args.flat_radius)
