"""Real LfD-layout data: the best that any of our shape models can do with the given boxes, association included.

Each object's own boxes (the files' columns: the true association) are fitted with every shape model the default
method may choose (spheroid, yawed ellipsoid, upright cylinder and cuboid; each upright plus yaw and with its
orientation free), and an oracle keeps, per object, the fit whose centre lies nearest the ground truth. No method that
fits one of these models to the boxes does better on average, whatever it knows; where the oracle misses a target, the
target asks for information that the boxes do not carry (on Aldoma: the two bottles' ground-truth ellipsoids sit 13-15
mm below the centre of every centrally symmetric model of their boxes, ``experiments/real_box_offsets.py``).

Printed: per object the error of each model (all views) and the oracle's; the oracle's mean / max over all views and
its mean / median / p90 / max over every subset of 3 views; each model alone over the subsets.

Usage: python experiments/real_floor.py [--data FOLDER]   (default: the shared Aldoma set, as ``bench real``; about a
minute on Aldoma)
"""

from __future__ import annotations

import argparse
import itertools
import warnings

import numpy as np

from monovisual3d.bench.real import ALDOMA_RELATIVE, default_folder
from monovisual3d.errors import InputError
from monovisual3d.geometry.fit import fit_shape_by_bic
from monovisual3d.io.lfd import read_lfd
from monovisual3d.methods.bayes.sensor import SensorModel
from monovisual3d.session import Session

MODELS = ("spheroid", "ellipsoid", "cylinder", "cuboid")
SUBSET_VIEWS = 3
UP = np.array([0.0, 0.0, 1.0])  # the LfD files' world z is up (the table's normal)
SEMI_AXIS_RANGE_M = (0.005, 0.3)  # wide: the oracle is not held back by a size prior


def model_errors_mm(camera, T_base_optical, boxes_xyxy, centre_base) -> dict[str, float]:
    """Centre error (mm) of each model fitted to one object's boxes, keyed ``model`` or ``model free`` (orientation
    free); models that cannot be fitted from these views are absent."""
    sensor = SensorModel()
    out = {}
    for model in MODELS:
        for free in (False, True):
            try:
                best, _ = fit_shape_by_bic(
                    camera,
                    T_base_optical,
                    boxes_xyxy,
                    shapes=(model,),
                    up=UP,
                    size_range=SEMI_AXIS_RANGE_M,
                    box_sigma=sensor.alpha,
                    edge_sigma_px=sensor.sigma0_px,
                    border_px=sensor.border_px,
                    free_orientation=free,
                )
            except InputError:
                continue
            out[model + (" free" if free else "")] = 1e3 * float(np.linalg.norm(best.ellipsoid.centre_base - centre_base))
    return out


def load(folder: str) -> tuple[Session, dict]:
    """The LfD folder's session and ground truth, with the detections' track ids (the true association)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the clipped box's warning
        return read_lfd(folder, keep_association=True)


def main(session: Session, truth: dict) -> None:
    centres = np.array([o["position"] for o in truth["objects"]])
    poses = np.array([v.T_base_optical for v in session.views])
    # boxes[k, f]: object k's box in view f (NaN where it has none)
    boxes = np.full((len(centres), len(poses), 4), np.nan)
    for f, view in enumerate(session.views):
        for d in view.detections:
            boxes[d.track, f] = d.bbox_xyxy

    def errors(views: tuple[int, ...]) -> list[dict[str, float]]:
        out = []
        for k, c in enumerate(centres):
            seen = [f for f in views if np.all(np.isfinite(boxes[k, f]))]
            out.append(model_errors_mm(session.camera, poses[seen], boxes[k, seen], c) if len(seen) >= 2 else {})
        return out

    every = errors(tuple(range(len(poses))))
    names = [*every[0]]
    print("object  " + "  ".join(f"{n:>14}" for n in names) + "          oracle")
    for k, e in enumerate(every):
        print(f"{k:6d}  " + "  ".join(f"{e.get(n, np.nan):14.1f}" for n in names) + f"  {min(e.values()):14.1f}")
    best_all = np.array([min(e.values()) for e in every])
    print(f"all {len(poses)} views, oracle: mean {best_all.mean():.2f} mm, max {best_all.max():.1f} mm")
    per_model: dict[str, list[float]] = {n: [] for n in names}
    oracle = []
    for views in itertools.combinations(range(len(poses)), SUBSET_VIEWS):
        for e in errors(views):
            if e:
                oracle.append(min(e.values()))
                for n in names:
                    per_model[n].append(e.get(n, np.nan))
    o = np.array(oracle)
    print(
        f"{SUBSET_VIEWS}-view subsets, oracle: mean {o.mean():.2f}, median {np.median(o):.2f}, "
        f"p90 {np.percentile(o, 90):.2f}, max {o.max():.1f} mm ({len(o)} object-subsets)"
    )
    for n in names:
        a = np.array(per_model[n])
        print(f"  {n:>14} alone: mean {np.nanmean(a):.2f}, p90 {np.nanpercentile(a, 90):.2f} mm, not fitted {np.isnan(a).sum()}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--data", default=default_folder(), help=f"folder of LfD arrays (default: the shared Aldoma set, {ALDOMA_RELATIVE})"
    )
    args = parser.parse_args()
    if args.data is None:
        parser.error(f"--data: not given, and the shared Aldoma set is not at {ALDOMA_RELATIVE}; give the folder of LfD arrays")
    try:
        data = load(str(args.data))
    except InputError as exc:
        parser.error(str(exc))
    main(*data)
