"""Do the session's variance factors tell a noisier detector from boxes cut by leaves?

Question: the ``bayes`` method localises a session again with a larger edge noise where its boxes scatter beyond the
sensor model's (``methods/bayes/edge_noise.py``). Which sessions does that rule select: the clean sessions of ``bench
trust`` (``monovisual3d.bench.trust_cases``) at 2, 5 and 10 % box noise (the model says 5 %), every session of ``bench
accuracy`` (5 % box noise at most, leaf occlusion, clutter, pose errors) and the 3-5 view subsets of ``bench real``'s
Aldoma set (where ``../shared`` holds it)? For each, the first estimate's clipped variance factor
(``quality.variance_factor``) and median-residual factor (``quality.robust_factor``), with the noise as stated.

Answer (2026-12-07, seeds 4-15 at 10 %, 4-9 at 2 and 5 %): see docs/decisions/bayes-quality.md#the-sessions-edge-noise.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from monovisual3d.api import localize
from monovisual3d.bench import accuracy
from monovisual3d.bench.real import default_folder, view_sets
from monovisual3d.bench.trust_cases import FAMILIES, make_case
from monovisual3d.io.lfd import read_lfd
from monovisual3d.methods.bayes.edge_noise import ADAPT_FACTOR, ADAPT_ROBUST_FACTOR, adapted_alpha
from monovisual3d.session.model import Session


def factors(session: Session, **options: object) -> tuple[float, float, int]:
    """The first estimate's clipped and median-residual variance factors and degrees of freedom."""
    q = localize(session, edge_noise="stated", **options).quality
    return float(q.get("variance_factor", 1.0)), float(q.get("robust_factor", 1.0)), int(q.get("dof", 0))


def report(label: str, rows: list[tuple[str, float, float, int]]) -> None:
    """Quantiles of both factors and the sessions above both thresholds (:func:`adapted_alpha`; the method also leaves
    out a session its first estimate flags)."""
    if not rows:
        return
    F, R = np.array([r[1] for r in rows]), np.array([r[2] for r in rows])
    q = [0, 0.25, 0.5, 0.75, 1]
    picked = [r for r in rows if adapted_alpha(0.05, {"variance_factor": r[1], "robust_factor": r[2], "dof": r[3]})]
    print(
        f"| {label} | {len(rows)} | {' / '.join(f'{x:.2f}' for x in np.quantile(F, q))} | "
        f"{' / '.join(f'{x:.2f}' for x in np.quantile(R, q))} | {len(picked)} |"
    )
    high = [r[0] for r in rows if r[1] > ADAPT_FACTOR and r not in picked]
    if high:
        print(f"  clipped factor above {ADAPT_FACTOR} but median factor not above {ADAPT_ROBUST_FACTOR}: {', '.join(high)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="4-9", help="bench trust seeds, FIRST-LAST (default 4-9)")
    parser.add_argument("--noises", default="0.02,0.05,0.10", help="box noise levels of the bench trust sessions")
    parser.add_argument("--accuracy", action="store_true", help="also every bench accuracy session (a few minutes)")
    parser.add_argument("--real", action="store_true", help="also the Aldoma set's 3-5 view subsets (where present)")
    args = parser.parse_args()
    first, last = (int(x) for x in args.seeds.split("-"))
    warnings.simplefilter("ignore")
    print("| sessions | count | clipped factor min / 25 % / median / 75 % / max | median-residual factor | above both |")
    print("|---|---:|---|---|---:|")
    for noise in (float(x) for x in args.noises.split(",")):
        rows = []
        for seed in range(first, last + 1):
            for family in FAMILIES:
                rows.append((f"{family} {seed}", *factors(make_case(family, seed, noise).session)))
        report(f"bench trust clean, {noise:.0%} box noise, seeds {first}-{last}", rows)
    if args.accuracy:
        rows = []
        for cond in accuracy.conditions(quick=False):
            for seed in cond.seeds:
                session, _ = accuracy.simulated_session(cond.scene(seed), cond.noise, seed, masks=cond.masks)
                rows.append((f"{cond.name} {seed}", *factors(session, **cond.method_options("bayes"))))
        report("bench accuracy, every condition and seed", rows)
    folder = default_folder()
    if args.real and folder is not None:
        real, _ = read_lfd(str(folder), keep_association=False)
        rows = []
        for k in (3, 4, 5):
            for views in view_sets(len(real.views), k):
                rows.append((f"views {views}", *factors(Session(real.camera, tuple(real.views[i] for i in views)))))
        report("bench real, 3-5 view subsets", rows)


if __name__ == "__main__":
    main()
