"""Does a change move any result of the default method? Save every object's position, radius and covariance on the
sessions of the benchmarks (each quick ``bench accuracy`` condition, ``bench real``'s 3-view subsets of the Aldoma
set where it is present, ``bench scale`` rows), once per version of the code, and compare the two files.

Run ``PYTHONPATH=<src of one version> python experiments/same_results.py save OUT.json [--full]`` for each version,
then ``python experiments/same_results.py compare A.json B.json [--ignore-covariance]``: it prints the differences
beyond 1e-9 m (positions, radii) and 1e-12 m^2 (covariances) and their count.
"""

from __future__ import annotations

import argparse
import json
import warnings
from typing import Any

import numpy as np

#: Largest difference of a position or radius (metres), and of a covariance entry (m^2), counted as none.
TOL_M, TOL_COV = 1e-9, 1e-12


def _objects(result: Any) -> list[dict[str, Any]]:
    return [
        {
            "p": [float(x) for x in o.position],
            "r": None if o.radius is None else float(o.radius),
            "c": None if o.covariance is None else np.asarray(o.covariance).ravel().tolist(),
        }
        for o in result.objects
    ]


def save(path: str, full: bool) -> int:
    """Localise the bench sessions with the default method and write their objects to ``path``; the session count."""
    from monovisual3d.api import localize
    from monovisual3d.bench import accuracy
    from monovisual3d.bench.real import default_folder, view_sets
    from monovisual3d.bench.scale import row_session
    from monovisual3d.io.lfd import read_lfd
    from monovisual3d.session.model import Session

    warnings.simplefilter("ignore")
    out: dict[str, Any] = {}
    for cond in accuracy.conditions(quick=True):
        for seed in cond.seeds[: 2 if full else 1]:
            session, _ = accuracy.simulated_session(cond.scene(seed), cond.noise, seed, masks=cond.masks)
            out[f"accuracy/{cond.name}/{seed}"] = _objects(localize(session, **cond.method_options("bayes")))
    folder = default_folder()
    if folder is not None:
        real, _ = read_lfd(str(folder), keep_association=False)
        for views in view_sets(len(real.views), 3)[: 8 if full else 3]:
            sub = Session(real.camera, tuple(real.views[i] for i in views))
            out[f"real/{views}"] = _objects(localize(sub))
    for n in (12, 48, 96) if full else (12, 48):
        session, _ = row_session(n, 5, 0)
        out[f"scale/{n}"] = _objects(localize(session))
    with open(path, "w") as f:
        json.dump(out, f)
    return len(out)


def compare(a_path: str, b_path: str, ignore_covariance: bool) -> int:
    """Print each difference between two saved files; their count."""
    with open(a_path) as f:
        a = json.load(f)
    with open(b_path) as f:
        b = json.load(f)
    bad = 0
    for key, objs in a.items():
        other = b.get(key)
        if other is None or len(other) != len(objs):
            print(f"{key}: {len(objs)} objects against {None if other is None else len(other)}")
            bad += 1
            continue
        for i, (o, p) in enumerate(zip(objs, other)):
            if np.max(np.abs(np.subtract(o["p"], p["p"]))) > TOL_M:
                print(f"{key} object {i}: position")
                bad += 1
            if (o["r"] is None) != (p["r"] is None) or (o["r"] is not None and abs(o["r"] - p["r"]) > TOL_M):
                print(f"{key} object {i}: radius")
                bad += 1
            if not ignore_covariance and (o["c"] is None) != (p["c"] is None):
                print(f"{key} object {i}: covariance given in one only")
                bad += 1
            elif not ignore_covariance and o["c"] is not None and np.max(np.abs(np.subtract(o["c"], p["c"]))) > TOL_COV:
                print(f"{key} object {i}: covariance")
                bad += 1
    print(f"{len(a)} sessions, {bad} differences")
    return bad


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    s = sub.add_parser("save", help="localise the bench sessions and save their objects")
    s.add_argument("output")
    s.add_argument("--full", action="store_true", help="two seeds per condition, 8 real subsets, a 96-fruit row")
    c = sub.add_parser("compare", help="compare two saved files")
    c.add_argument("a")
    c.add_argument("b")
    c.add_argument("--ignore-covariance", action="store_true", help="positions and radii only")
    args = parser.parse_args()
    if args.command == "save":
        print(f"{save(args.output, args.full)} sessions saved to {args.output}")
    else:
        raise SystemExit(1 if compare(args.a, args.b, args.ignore_covariance) else 0)


if __name__ == "__main__":
    main()
