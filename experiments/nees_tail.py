"""Where does the covariance's tail at 10 % box noise come from?

Question: on the clean sessions of ``bench trust`` (``monovisual3d.bench.trust_cases``) at one box noise level, which
fruit lie beyond their 95 % ellipsoid (NEES > 7.81): is it the fruit whose shape the method fitted as other than a
sphere (every simulated fruit is a sphere), the fruit with the largest boxes (the sensor model's noise, ``alpha * size +
sigma0``, grows more slowly with the box than a detector's that is 10 % off), or along which axis of the ellipsoid the
error lies (the smallest: across the line of sight; the largest: along it)?

Each session is localised as ``localize --strict`` would (``monovisual3d.bench.trust_runs.run_session``, no run
limit); each object is paired with a true fruit as ``bench trust`` pairs them.

Answer (2026-12-07, seeds 4-9, all four families, 10 % box noise): see docs/decisions/bayes-quality.md#the-tail-at-10-box-noise.
"""

from __future__ import annotations

import argparse

import numpy as np

from monovisual3d import localize
from monovisual3d.bench.trust_cases import FAMILIES, make_case
from monovisual3d.bench.trust_runs import NEES_95, is_positive_definite
from monovisual3d.metrics import match


def fruit_rows(
    family: str, seed: int, noise: float, alpha: float | None = None, edge_noise: str = "auto"
) -> list[dict[str, float | str]]:
    """One row per object paired with a true fruit within its radius: NEES, fitted shape, smallest semi-axis (mm),
    angular size (radius over distance to the nearest camera), error along the ellipsoid's axes in its sigmas."""
    import warnings

    case = make_case(family, seed, noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = localize(case.session, edge_noise=edge_noise, **({} if alpha is None else {"alpha": alpha}))
    cams = np.array([np.asarray(v.T_base_optical)[:3, 3] for v in case.session.views])
    rows = []
    if not len(result.positions):
        return rows
    for e, t in zip(*match(result.positions, case.centres)):
        obj, err = result.objects[e], result.positions[e] - case.centres[t]
        C = None if obj.covariance is None else np.asarray(obj.covariance, dtype=float)
        if np.linalg.norm(err) > case.radii[t] or C is None or not is_positive_definite(C):
            continue
        w, V = np.linalg.eigh(C)
        semi = np.asarray(obj.semi_axes if obj.semi_axes is not None else [obj.radius] * 3, dtype=float)
        rows.append(
            {
                "family": family,
                "nees": float(err @ np.linalg.solve(C, err)),
                "shape": str(obj.shape or "sphere"),
                "min_semi_mm": float(semi.min() * 1e3),
                "angular": float(case.radii[t] / np.min(np.linalg.norm(cams - case.centres[t], axis=1))),
                "z_small": float((V[:, 0] @ err) / np.sqrt(w[0])),
                "z_large": float((V[:, 2] @ err) / np.sqrt(w[2])),
            }
        )
    return rows


def summary(label: str, nees: np.ndarray) -> str:
    if not len(nees):
        return f"| {label} | 0 | - | - |"
    return f"| {label} | {len(nees)} | {nees.mean():.2f} | {np.mean(nees > NEES_95):.1%} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("first_seed", type=int)
    parser.add_argument("end_seed", type=int, help="one past the last seed")
    parser.add_argument("--families", default=",".join(FAMILIES))
    parser.add_argument("--noise", type=float, default=0.10)
    parser.add_argument("--alpha", type=float, help="the sensor model's edge noise (localize --alpha; default its own)")
    parser.add_argument(
        "--edge-noise", default="auto", choices=("auto", "stated"), help="localize --edge-noise (stated: before it existed)"
    )
    args = parser.parse_args()
    rows = [
        r
        for seed in range(args.first_seed, args.end_seed)
        for family in args.families.split(",")
        for r in fruit_rows(family, seed, args.noise, args.alpha, args.edge_noise)
    ]
    nees = np.array([r["nees"] for r in rows])
    print(f"box noise {args.noise:g}, seeds {args.first_seed}-{args.end_seed - 1}")
    print("| fruit | count | mean NEES | beyond 95 % |\n|---|---:|---:|---:|")
    print(summary("all", nees))
    for shape in sorted({str(r["shape"]) for r in rows}):
        sel = np.array([r["shape"] == shape for r in rows])
        print(summary(f"fitted as {shape}", nees[sel]))
    angular = np.array([r["angular"] for r in rows])
    edges = np.quantile(angular, [0, 0.25, 0.5, 0.75, 1]) if len(rows) else []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (angular >= lo) & (angular <= hi)
        print(summary(f"radius / distance {lo:.3f}-{hi:.3f}", nees[sel]))
    for family in args.families.split(","):
        sel = np.array([r["family"] == family for r in rows])
        print(summary(family, nees[sel]))
    if rows:
        for axis, name in (("z_small", "smallest"), ("z_large", "largest")):
            z = np.array([r[axis] for r in rows])
            print(f"error along the ellipsoid's {name} axis, in its sigmas: mean {z.mean():+.2f}, variance {z.var():.2f}")
        flat = [r for r in rows if r["shape"] != "sphere"]
        if flat:
            semis = ", ".join(f"{r['min_semi_mm']:.0f}" for r in flat)
            print(f"smallest semi-axis of the objects not fitted as spheres (mm): {semis}")


if __name__ == "__main__":
    main()
