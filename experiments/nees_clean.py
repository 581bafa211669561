"""Does the default's covariance cover its error on clean sessions, and how often does a clean session raise an alarm?

Question: over the clean sessions of ``bench trust`` (``monovisual3d.bench.trust_cases``: the paper scene, a greenhouse
truss, arcs of views with a distorted lens) at 2, 5 and 10 % box noise, what is the mean NEES of the fruit paired with
the truth (3 when calibrated, issue 53 asks 2.2-4.0) and the share beyond the 95 % ellipsoid (5 % when calibrated, at
most 10 % asked), and what share of the sessions gets any warning or a verdict that is not ``ok`` (at most 10 %)?
Each session is localised as ``localize --strict`` would (``monovisual3d.bench.trust_runs.run_session``).

With ``--seed-pairs``, the same per sample of two consecutive seeds (the size of one ``bench trust`` run): the range of
the mean NEES and the largest share beyond, and how many samples fall outside the issue's targets.

With ``--save``, the positions of every session are written as JSON; ``--compare`` reads such a file and prints the
largest difference of the positions (a change that must not move the estimates: 0).

Answer (2026-12-07, the quality pass of ``monovisual3d.methods.bayes.quality``): see experiments/README.md and
docs/decisions/bayes-quality.md.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from monovisual3d.bench.trust_cases import make_case
from monovisual3d.bench.trust_runs import NEES_95, clean_record, run_session


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("first_seed", type=int)
    parser.add_argument("end_seed", type=int, help="one past the last seed")
    parser.add_argument("--families", default="paper,greenhouse,arc")
    parser.add_argument("--noises", default="0.02,0.05,0.10")
    parser.add_argument("--seed-pairs", action="store_true", help="also the spread over samples of two consecutive seeds")
    parser.add_argument("--save", help="write the positions of every session here (JSON)")
    parser.add_argument("--compare", help="a --save file of another run: print the largest position difference")
    args = parser.parse_args()
    noises = [float(x) for x in args.noises.split(",")]
    records = []
    for seed in range(args.first_seed, args.end_seed):
        for family in args.families.split(","):
            for noise in noises:
                case = make_case(family, seed, noise)
                outcome = run_session(case.session, limit_s=None)
                record = clean_record(outcome, case.centres, case.radii)
                record.update(family=family, seed=seed, noise=noise, positions=outcome.positions.tolist())
                records.append(record)
    print(
        "| box noise | sessions | fruit | mean NEES | median NEES (a chi-square's: 2.37) | beyond 95 % | no covariance | with an alarm |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for noise in noises:
        rs = [r for r in records if r["noise"] == noise]
        nees = np.array([v for r in rs for v in r["nees"] if v is not None])
        missing = sum(r["no_covariance"] + r["not_pd"] for r in rs)
        alarms = np.mean([r["alarm"] for r in rs])
        print(
            f"| {noise:g} | {len(rs)} | {len(nees)} | {nees.mean():.2f} | {np.median(nees):.2f} | {np.mean(nees > NEES_95):.1%} | "
            f"{missing} | "
            f"{alarms:.0%} |"
        )
    if args.seed_pairs:
        print_seed_pairs(records, noises, range(args.first_seed, args.end_seed - 1, 2))
    for r in records:
        if r["alarm"]:
            print(f"alarm: {r['family']} seed {r['seed']} noise {r['noise']:g}: {r['verdict']} {r['messages'][:1]}")
    if args.save:
        with open(args.save, "w") as f:
            json.dump([{k: r[k] for k in ("family", "seed", "noise", "positions")} for r in records], f)
    if args.compare:
        with open(args.compare) as f:
            other = {(r["family"], r["seed"], r["noise"]): np.array(r["positions"]).reshape(-1, 3) for r in json.load(f)}
        worst = 0.0
        for r in records:
            theirs, ours = other.get((r["family"], r["seed"], r["noise"])), np.array(r["positions"]).reshape(-1, 3)
            if theirs is not None:
                worst = max(worst, float(np.abs(theirs - ours).max(initial=0.0)) if theirs.shape == ours.shape else np.inf)
        print(f"largest position difference against {args.compare}: {worst:.3g} m")


def print_seed_pairs(records: list[dict], noises: list[float], starts: range) -> None:
    """Per box noise, over the samples of seeds ``(s, s + 1)``: the range of the mean NEES, the largest share beyond
    the 95 % ellipsoid, and the samples with a mean outside 2.2-4.0 or more than 10 % beyond."""
    print(
        "| box noise | two-seed samples | mean NEES: least - most | beyond 95 %: most | mean outside 2.2-4.0 | over 10 % beyond |"
    )
    print("|---:|---:|---|---:|---:|---:|")
    for noise in noises:
        means, beyond = [], []
        for s in starts:
            nees = np.array(
                [v for r in records if r["noise"] == noise and r["seed"] in (s, s + 1) for v in r["nees"] if v is not None]
            )
            if len(nees):
                means.append(nees.mean())
                beyond.append(np.mean(nees > NEES_95))
        if not means:
            print(f"| {noise:g} | 0 | no two-seed sample | - | - | - |")
            continue
        outside = sum(not 2.2 <= m <= 4.0 for m in means)
        print(
            f"| {noise:g} | {len(means)} | {min(means):.2f} - {max(means):.2f} | {max(beyond):.1%} | {outside} | "
            f"{sum(b > 0.10 for b in beyond)} |"
        )


if __name__ == "__main__":
    main()
