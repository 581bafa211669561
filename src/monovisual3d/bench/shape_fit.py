"""Shape-fit benchmark: known-association fits on non-spherical fruit against the Cramer-Rao bound.

For each seed a shape scene (:func:`~monovisual3d.sim.scenes.shapes_scene`) is
seen from the paper's three poses with exact boxes (``clean``) and with the
paper's box noise (``noise``: 5 % box noise, no drops). Every fruit is fitted
from its own boxes (the association is known: this measures the shape model and
the fit, not the association) with each model of :data:`MODELS`
(:func:`~monovisual3d.geometry.fit.fit_ellipsoid_to_boxes`, true poses). Per
model: RMS and mean centre error, mean semi-axis error (sorted axes), and for
the noisy boxes the RMS Cramer-Rao bound of the same model
(:func:`~monovisual3d.geometry.bounds.ellipsoid_crlb`).

Run: ``python -m monovisual3d.bench.shape_fit [--seeds N] [--scene mixed]``.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from ..geometry.bounds import ellipsoid_crlb
from ..geometry.fit import fit_ellipsoid_to_boxes
from ..sim.noise import PAPER_BOX_SIGMA, NoiseModel
from ..sim.scenes import default_camera, shapes_scene
from ..sim.simulate import simulate_views

#: (shape, free_orientation) pairs fitted.
MODELS: tuple[tuple[str, bool], ...] = (("sphere", False), ("spheroid", False), ("ellipsoid", False), ("spheroid", True))


def run_shape_fit(seeds: int = 8, scene: str = "mixed") -> dict[str, Any]:
    """Run the benchmark; returns a JSON-ready dict ``{"rows": {condition: {model: stats}}, ...}``."""
    camera = default_camera()
    rows: dict[str, dict[str, Any]] = {}
    for condition, noise in (("clean", NoiseModel()), ("noise", NoiseModel(box_sigma=PAPER_BOX_SIGMA))):
        acc: dict[str, dict[str, list[float]]] = {}
        for seed in range(seeds):
            sc = shapes_scene(scene, rng=seed)
            svs = simulate_views(sc, camera, noise=noise, rng=1000 + seed)
            for i, fruit in enumerate(sc.fruits):
                seen = [
                    (sv.T_base_optical_true, sv.boxes_xyxy[np.flatnonzero(sv.source == i)[0]]) for sv in svs if i in sv.source
                ]
                if len(seen) < 2:
                    continue
                T = np.array([s[0] for s in seen])
                b = np.array([s[1] for s in seen])
                truth = fruit.ellipsoid  # type: ignore[union-attr]
                for shape, free in MODELS:
                    name = f"{shape}{' free' if free else ''}"
                    a = acc.setdefault(name, {"sq": [], "axis": [], "bound": [], "time": []})
                    t0 = time.perf_counter()
                    fit = fit_ellipsoid_to_boxes(camera, T, b, shape=shape, free_orientation=free)
                    a["time"].append(time.perf_counter() - t0)
                    a["sq"].append(float(np.sum((fit.ellipsoid.centre_base - truth.centre_base) ** 2)))
                    a["axis"].append(float(np.mean(np.abs(np.sort(fit.ellipsoid.semi_axes) - np.sort(truth.semi_axes)))))
                    if noise.box_sigma > 0:
                        bound = ellipsoid_crlb(camera, T, truth, noise.box_sigma, shape, free_orientation=free).centre_rms_sq
                        if np.isfinite(bound):
                            a["bound"].append(bound)
        rows[condition] = {
            name: {
                "n": len(a["sq"]),
                "rms_mm": float(np.sqrt(np.mean(a["sq"])) * 1e3),
                "mean_mm": float(np.mean(np.sqrt(a["sq"])) * 1e3),
                "semi_axis_error_mm": float(np.mean(a["axis"]) * 1e3),
                **({"rms_bound_mm": float(np.sqrt(np.mean(a["bound"])) * 1e3)} if a["bound"] else {}),
                "median_fit_ms": float(np.median(a["time"]) * 1e3),
            }
            for name, a in acc.items()
        }
    return {"scene": scene, "seeds": seeds, "views": "paper", "rows": rows}


def markdown(results: dict[str, Any]) -> str:
    """The results as a markdown table."""
    lines = [
        "| condition | model | RMS centre mm | mean centre mm | semi-axis error mm | CRB RMS mm | median fit ms |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for cond, models in results["rows"].items():
        for name, r in models.items():
            bound = f"{r['rms_bound_mm']:.2f}" if "rms_bound_mm" in r else "-"
            lines.append(
                f"| {cond} | {name} | {r['rms_mm']:.2f} | {r['mean_mm']:.2f} | {r['semi_axis_error_mm']:.2f} | {bound} | {r['median_fit_ms']:.0f} |"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--scene", default="mixed")
    parser.add_argument("--json", default=None, help="also write the results here")
    args = parser.parse_args(argv)
    results = run_shape_fit(args.seeds, args.scene)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=2)
    print(markdown(results))


if __name__ == "__main__":
    main()
