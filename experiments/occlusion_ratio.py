"""RMS centre error of the default method against the cut-edge Cramer-Rao bound, on seeds of your choice.

The accuracy benchmark's ``greenhouse-noise`` (leaf occlusion) and ``greenhouse-clutter`` (false-positive boxes)
rows use seeds 0-19; this runs the same conditions (:func:`monovisual3d.bench.accuracy.measure_seed`, the
bench's own scenes, noise, matching and :func:`~monovisual3d.bench.accuracy.cut_crlb_rms_sq`) on other seeds,
so that a change to the estimator is judged on scenes it was not tuned on.

Usage::

    python experiments/occlusion_ratio.py [FIRST LAST]   # seeds FIRST..LAST-1, default 1000 1040

Prints first how far the true boxes' edges lie from the full silhouette box, inside and outside (occlusion only
shrinks a box), then, per condition, the RMS error (mm), the RMS bound (mm), their ratio, a 90 % bootstrap interval
of the ratio over seeds (2000 resamples of the seeds, seeded), the ratio without matched errors over 20 mm
(association failures, which dominate the clutter RMS on some seed sets) and their count, and the recall.

What was tried (issue 20: leaf occlusion and false positives <= 1.15x their bounds), the shape stage's final sphere
refit, ``ratio`` (``trimmed``), before -> after:

- iterative censoring: after the fit, each edge more than ``c`` sensor sigmas inside its prediction censored (only
  its outward residual counts), refit until the censored set is stable. Tuning seeds 2000-2029, noise / clutter:
  c = 1.5: 1.209 / 1.165 trimmed, c = 2: 1.200 / 1.155, none: 1.207 / 1.161. The fit takes a third of a cut, so only
  cuts over about 3 sigmas are caught, and the robust loss already ignores most of those: not kept.
- a one-sided loss (a Gaussian plus a flat tail inward, an occluder's cut; the floor 6 nats outward), the inward floor
  swept on seeds 2000-2029 (see ``BayesConfig.cut_inward_floor``): 1.5 nats kept (1.153 / 1.132 trimmed). On two-view
  fruit it moved two clutter fruit past 20 mm (seeds 3000-3039), so it needs 3 views (``shapes.MIN_VIEWS_ONE_SIDED``).

Kept (one-sided loss, 3+ views), evaluated on seeds chosen before (``ratio``, ``trimmed``):

=================  ===============================  ===============================
seeds              greenhouse-noise                 greenhouse-clutter
=================  ===============================  ===============================
0-19 (benchmark)   1.312 -> 1.258                   1.259 -> 1.248
1000-1039          1.194 -> 1.169 (1.067 -> 1.039)  6.871 -> 6.872 (1.090 -> 1.098)
3000-3039          1.241 -> 1.201 (1.135 -> 1.123)  3.512 -> 3.502 (1.171 -> 1.141)
4000-4039 (last)   1.219 -> 1.184 (1.146 -> 1.132)  3.606 -> 3.601 (1.074 -> 1.047)
=================  ===============================  ===============================

Leaf occlusion gains 2-4 % on every seed set; clutter about 1 % where it moves at all (its RMS is set by a few
association failures, 5-7 per 40 seeds, over 20 mm, which the final fit cannot mend). The 1.15x target is met on
some seed sets, not reliably.

Later (2026-12-03, the steal pass giving a holder its own free box in exchange, ``methods/bayes/associate.py``):
greenhouse-noise 8000-8039 1.183 -> 1.145, recall 0.976 -> 0.983; 1000-1039 1.161, 3000-3039 1.173, 4000-4039 1.152
unchanged; clutter unchanged on all four (6.87, 3.50, 3.60, 1.56: one to three estimates per 40 seeds paired with a
missed fruit 0.1-0.6 m away, see docs/accuracy.md).
"""

from __future__ import annotations

import argparse

import numpy as np

from monovisual3d.bench.accuracy import conditions, measure_seed, simulated_session
from monovisual3d.geometry.ellipsoid import ellipsoid_bbox
from monovisual3d.methods.bayes.sensor import SensorModel, box_edge_sigma_px, censored_edges, inward_edge_offsets
from monovisual3d.sim.scenes import default_camera

#: Matched errors beyond this (metres) are association failures (a ghost or a swapped fruit matched to a truth),
#: not edge noise; the ``trimmed`` ratio leaves them out (the evaluation gate's 20 mm floor).
GROSS_M = 0.02
CONDITIONS = ("greenhouse-noise", "greenhouse-clutter")
#: Bootstrap resamples of the seeds for the ratio's interval, and their seed.
BOOTSTRAP, BOOTSTRAP_SEED = 2000, 7


def _ratio(err2: list[np.ndarray], bound_sq: list[np.ndarray], idx: np.ndarray) -> float:
    """RMS error over RMS bound of the seeds ``idx`` (squared errors and squared bounds per seed, m^2)."""
    e = np.concatenate([err2[i] for i in idx])
    b = np.concatenate([bound_sq[i] for i in idx])
    return float(np.sqrt(e.mean() / b.mean()))


def ratio_rows(seeds: range) -> dict[str, dict[str, float]]:
    """Per condition: ``rms_mm``, ``bound_mm``, ``ratio``, ``lo``, ``hi`` (90 % bootstrap over seeds), ``trimmed`` (the
    ratio without errors over :data:`GROSS_M`), ``gross`` (how many such errors) and ``recall``."""
    out = {}
    for name in CONDITIONS:
        per_seed = [measure_seed(name, False, s, ("bayes",))["bayes"] for s in seeds]
        err2 = [np.square(v["errors"]) for v in per_seed]
        bnd = [np.asarray(v["bound_sq"]) for v in per_seed]

        idx = np.arange(len(seeds))
        rng = np.random.default_rng(BOOTSTRAP_SEED)
        boot = [_ratio(err2, bnd, rng.choice(idx, len(idx))) for _ in range(BOOTSTRAP)]
        e_all, b_all = np.concatenate(err2), np.concatenate(bnd)
        kept = e_all[e_all < GROSS_M**2]
        tp = sum(v["true_positives"] for v in per_seed)
        out[name] = {
            "rms_mm": float(np.sqrt(e_all.mean()) * 1e3),
            "bound_mm": float(np.sqrt(b_all.mean()) * 1e3),
            "ratio": _ratio(err2, bnd, idx),
            "lo": float(np.percentile(boot, 5)),
            "hi": float(np.percentile(boot, 95)),
            "trimmed": float(np.sqrt(kept.mean() / b_all.mean())),
            "gross": int(len(e_all) - len(kept)),
            "recall": tp / sum(v["n_truth"] for v in per_seed),
        }
    return out


def edge_sides(
    seeds: range, name: str = "greenhouse-noise", sigmas: tuple[float, ...] = (1.0, 2.0, 3.0)
) -> dict[float, tuple[float, float]]:
    """The physical reason for one-sided censoring: the fraction of true boxes' edges lying more than ``s`` sensor
    sigmas inside (first) and outside (second) the fruit's full silhouette box, for each ``s`` in ``sigmas``.

    Each detection of a fruit (the simulator's true association) against the unclipped box of its true ellipsoid,
    normalised by the ``bayes`` sensor model's edge noise; edges on the image border are left out. Box noise alone
    is symmetric; occlusion (leaves, other fruit) adds only inward offsets.
    """
    cam, model = default_camera(), SensorModel()
    cond = next(c for c in conditions() if c.name == name)
    e_all = []
    for seed in seeds:
        scene = cond.scene(seed)
        _, svs = simulated_session(scene, cond.noise, seed, masks=False)
        for sv in svs:
            for box, f in zip(np.asarray(sv.boxes_xyxy, dtype=float), sv.source):
                if f < 0:
                    continue
                e = scene.fruits[f].ellipsoid
                full = ellipsoid_bbox(cam, sv.T_base_optical_true[None], e.centre_base, e.semi_axes, e.rotation, clip=False)[0]
                z = inward_edge_offsets(full, box) / box_edge_sigma_px(model, full)
                e_all.append(z[~censored_edges(box, cam.width, cam.height, model.border_px)])
    z = np.concatenate(e_all)
    return {s: (float(np.mean(z > s)), float(np.mean(z < -s))) for s in sigmas}


def main(first: int, last: int) -> None:
    sides = edge_sides(range(first, last))
    print("greenhouse-noise edges against the true full silhouette box (sensor sigmas): inside / outside")
    for k, (inside, outside) in sides.items():
        print(f"  |e| > {k:g}: {inside:.3f} inside, {outside:.3f} outside")
    rows = ratio_rows(range(first, last))
    print(f"seeds {first}-{last - 1}")
    print("| condition | RMS mm | bound mm | ratio | 90% interval | ratio without errors > 20 mm (count) | recall |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, r in rows.items():
        print(
            f"| {name} | {r['rms_mm']:.2f} | {r['bound_mm']:.2f} | {r['ratio']:.3f} | {r['lo']:.2f}-{r['hi']:.2f} | "
            f"{r['trimmed']:.3f} ({r['gross']}) | {r['recall']:.3f} |"
        )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("first", nargs="?", type=int, default=1000, help="first seed (default 1000)")
    parser.add_argument("last", nargs="?", type=int, default=1040, help="last seed, excluded (default 1040)")
    args = parser.parse_args()
    main(args.first, args.last)
