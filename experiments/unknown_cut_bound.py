"""Leaf occlusion: the Cramer-Rao bound when the estimator does not know which box edges are cut.

The accuracy benchmark's ``greenhouse-noise`` bound (:func:`monovisual3d.bench.accuracy.cut_crlb_rms_sq`) leaves out
every edge a leaf cuts, as if the estimator were told which ones. An estimator that is not told sees each edge with
a mixture density: uncut (the simulator's box noise about the silhouette's edge) or cut inward by some depth. Here
that density is taken from the simulator itself: per edge, the cut depth in units of the edge's noise scale
(``box_sigma`` times the visible box's size), zero where the visible edge lies within
:data:`~monovisual3d.geometry.bounds.CUT_PX` of the silhouette's (as the known-cut bound counts it), pooled over every
fruit of the seeds; the two edges of an axis keep the simulator's correlated noise, their cuts are taken as
independent. The Fisher information of an edge pair's location under that mixture is computed by numerical
integration on a grid (fine against the noise, so that the depth distribution stays continuous), and each fruit's
bound is then ``sum_views J^T I_mix J`` inverted, with the known-cut bound's Jacobians and noise scales.

The mixture bound uses the information expected over cut patterns, the benchmark's known-cut bound each fruit's own
pattern, which by Jensen's inequality weighs heavily cut fruit more; so the known-cut bound is also given averaged
as the mixture is (each edge cut with the pooled probability, its information then lost): the cost of not knowing
which edges are cut is the mixture bound against that one. An estimator that is not told cannot beat one that is,
so a mixture bound below the benchmark's known-cut bound cannot show the target out of reach.

Usage: python experiments/unknown_cut_bound.py [CONDITION FIRST LAST]   (default greenhouse-noise 0 20)
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.signal import fftconvolve

from monovisual3d.bench.accuracy import conditions
from monovisual3d.bench.leaf_cuts import PAIR_COVARIANCE, edge_noise_density, fruit_boxes, pair_noise_density

#: Grid step of the numerical integration and its half-width beyond the cuts, in units of the edge noise scale.
STEP, PAD = 0.04, 8.0
#: Cut depths beyond this (noise-scale units; slivers of a fruit behind a leaf) are spread evenly over
#: [TAIL_FROM, CAP]: such an edge is clearly cut either way, and the grid stays small.
TAIL_FROM, CAP = 50.0, 60.0


def mixture_information(depths: np.ndarray) -> tuple[np.ndarray, float]:
    """Fisher information (noise-scale units) of an axis's two edge locations (2, 2) and of one edge alone, when each
    edge is cut inward by a depth drawn from ``depths`` (samples, 0: uncut), independently."""
    d = depths.copy()
    far = d > CAP
    d[far] = TAIL_FROM + (CAP - TAIL_FROM) * (np.arange(far.sum()) + 0.5) / max(far.sum(), 1)
    g = np.bincount(np.rint(d / STEP).astype(int)).astype(float)
    g /= g.sum()
    _, u, density = pair_noise_density(STEP, PAD)
    inv = np.linalg.inv(PAIR_COVARIANCE)
    mass = density * STEP**2
    slope = -np.einsum("ij,...j->...i", inv, u) * mass[..., None]
    cuts = np.outer(g, g[::-1])  # the first edge moves in by +depth, the second by -depth
    p = fftconvolve(cuts, mass)
    grads = [fftconvolve(cuts, slope[..., k]) for k in range(2)]
    ok = p > 1e-300
    pair = np.array([[np.sum(a[ok] * b[ok] / p[ok]) for b in grads] for a in grads])
    var = PAIR_COVARIANCE[0, 0]
    x = np.arange(-1.2 * PAD, 1.2 * PAD + STEP / 2, STEP)
    m1 = edge_noise_density(x) * STEP
    p1, s1 = np.convolve(g, m1), np.convolve(g, -x / var * m1)
    ok1 = p1 > 1e-300
    return pair, float(np.sum(s1[ok1] ** 2 / p1[ok1]))


def known_information(q: float) -> tuple[np.ndarray, float]:
    """Fisher information (noise-scale units) of an axis's two edge locations (2, 2) and of one edge alone when each
    edge is cut with probability ``q``, independently, and the estimator is told which (a cut edge then tells
    nothing), in expectation over the cut patterns."""
    single = 1.0 / PAIR_COVARIANCE[0, 0]
    pair = (1 - q) ** 2 * np.linalg.inv(PAIR_COVARIANCE) + q * (1 - q) * single * np.eye(2)
    return pair, (1 - q) * single


def fruit_bound_sq(J: np.ndarray, seen: np.ndarray, usable: np.ndarray, sigma: float, pair: np.ndarray, single: float) -> float:
    """Trace of the centre bound (m^2) of one fruit whose edge pairs carry ``pair`` and lone edges ``single`` (noise-
    scale units); NaN where the information is singular."""
    F = np.zeros((J.shape[2], J.shape[2]))
    for v in range(len(J)):
        for i, k in ((0, 2), (1, 3)):
            s2 = (sigma * (seen[v, k] - seen[v, i])) ** 2
            if usable[v, i] and usable[v, k]:
                F += J[v, [i, k]].T @ pair @ J[v, [i, k]] / s2
            elif usable[v, i] or usable[v, k]:
                j = i if usable[v, i] else k
                F += np.outer(J[v, j], J[v, j]) * single / s2
    if np.linalg.cond(F) > 1e12:
        return float("nan")
    return float(np.trace(np.linalg.inv(F)[:3, :3]))


def main(name: str, seeds: range) -> None:
    sigma = next(c for c in conditions(False) if c.name == name).noise.box_sigma
    records = list(fruit_boxes(name, seeds))
    fruit = [(b.J, b.seen, b.usable, b.known_sq) for b in records]
    d = np.concatenate([b.depths for b in records])
    pair, single = mixture_information(d)
    print(
        f"{name} seeds {seeds.start}-{seeds.stop - 1}: {len(fruit)} fruit, {d.size} usable edges, {np.mean(d > 0):.3f} cut; "
        f"cut depth (noise-scale units) median {np.median(d[d > 0]):.1f}, p90 {np.percentile(d[d > 0], 90):.1f}"
    )
    print(
        f"information of an edge pair, uncut {np.round(np.linalg.inv(PAIR_COVARIANCE), 3).tolist()}, mixture {np.round(pair, 3).tolist()};"
    )
    print(f"of one edge, uncut {1 / PAIR_COVARIANCE[0, 0]:.3f}, mixture {single:.3f}")
    known_pair, known_single = known_information(float(np.mean(d > 0)))
    rows = []
    for J, seen, usable, known in fruit:
        mixed = fruit_bound_sq(J, seen, usable, sigma, pair, single)
        averaged = fruit_bound_sq(J, seen, usable, sigma, known_pair, known_single)
        if np.isfinite(known) and np.isfinite(mixed) and np.isfinite(averaged):  # the known-cut bound's own exclusions
            rows.append((known, averaged, mixed))
    k, a, m = np.sqrt(np.mean(rows, axis=0))
    print(
        f"RMS centre bound over {len(rows)} fruit: cuts known, each fruit's own (the benchmark's) {1e3 * k:.2f} mm; "
        f"cuts known, averaged over patterns {1e3 * a:.2f} mm; cuts unknown (mixture) {1e3 * m:.2f} mm "
        f"(+{100 * (m / a - 1):.1f} % over the averaged known-cut bound)"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("condition", nargs="?", default="greenhouse-noise", help="a bench accuracy condition (greenhouse-noise)")
    parser.add_argument("first", nargs="?", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("last", nargs="?", type=int, default=20, help="last seed, excluded (default 20)")
    args = parser.parse_args()
    if args.condition not in [c.name for c in conditions(False)]:
        parser.error(f"condition: got {args.condition!r}, expected one of {[c.name for c in conditions(False)]}")
    main(args.condition, range(args.first, args.last))
