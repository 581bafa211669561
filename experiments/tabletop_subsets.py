"""A table top of lying boxes and upright bottles, 8 views from one side and every 3 of them: which pairings survive.

A simulated counterpart of a real multi-view table-top set (Aldoma's, ``monovisual3d bench real``), drawn afresh per
seed (:func:`monovisual3d.sim.tabletop.tabletop_scene`): four objects lying on the table (ellipsoids 240 x 110 x 120 mm, random yaw: the shape stage's yawed ellipsoid,
so that its boxes test the association, not the model) and two bottles standing (cylinders of radius 40 mm and height
180 mm), their footprints apart in a 0.6 m square; 8 views at random azimuths over 180 degrees
(so some stand close together, as a hand-held or arm-held sequence does), 0.9-1.1 m from the table's middle and 35-40
degrees above it, 640 x 480 (fx = 528 px); each box the object's whole silhouette box with box noise
(:func:`monovisual3d.sim.noise.perturb_boxes`), pooled per view (no association). The default ``localize`` with
``size_range=(0.02, 0.15)`` (as ``bench real``) on all 8 views and on all 56 three-view subsets; each object is paired
with an estimate (Hungarian), missed beyond 50 mm.

Three views of which two stand close together are a two-viewpoint problem: two objects on one epipolar line can trade
their boxes in the third view and both still triangulate. Spheres explain a lying box's boxes poorly either way, so the
search and the sphere-level swap pass cannot tell the pairings apart; the shape models can
(``methods/bayes/shape_swap.py``, the trade of a view's boxes that the box centres allow).

Printed: 8 views mean / max (mm) and misses; the subsets' mean, median, p90 (mm) and misses; the subsets with a miss.

Usage: python experiments/tabletop_subsets.py [FIRST_SEED LAST_SEED] [NOISE] [--two-viewpoints] [--cuboids] [-- key=value ...]
(LAST_SEED excluded; default seeds 800-804, noise 0.01; ``--two-viewpoints``: :func:`two_viewpoints` instead; options
after ``--`` go to ``localize``, values read as JSON where they parse; ``--cuboids``: the lying objects are boxes, cuboids
of the same half-sides, as real boxes are).
"""

from __future__ import annotations

import argparse
import itertools
import sys
import warnings

import numpy as np
from scipy.optimize import linear_sum_assignment

import monovisual3d as mv
from monovisual3d.bench.option_ab import split_options
from monovisual3d.errors import InputError
from monovisual3d.session import Detection, Session, View
from monovisual3d.sim.noise import perturb_boxes
from monovisual3d.sim.tabletop import N_BOTTLES, N_LYING, N_VIEWS, tabletop_camera, tabletop_scene

CAMERA = tabletop_camera()
SUBSET = 3
#: An estimate further than this from its object does not count as finding it (metres).
FOUND_M = 0.05
SIZE_RANGE_M = (0.02, 0.15)


def errors_mm(estimates: np.ndarray, centres: np.ndarray) -> list[float]:
    """Per object, the distance (mm) to its Hungarian-paired estimate, NaN when missed (beyond ``FOUND_M``)."""
    out = [float("nan")] * len(centres)
    if len(estimates):
        d = np.linalg.norm(estimates[:, None] - centres[None], axis=2)
        for i, j in zip(*linear_sum_assignment(d)):
            if d[i, j] < FOUND_M:
                out[j] = 1e3 * d[i, j]
    return out


def two_viewpoints(seeds: range, sigma: float, options: dict) -> None:
    """Three views of which two stand 3 degrees of azimuth apart (their distances and elevations drawn apart: 4-22 cm,
    median 8 cm) and the third 40-120 degrees away, one run per seed: the objects each estimate takes its boxes from,
    against the truth."""
    mixed = missed = 0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        first = rng.uniform(-90.0, 30.0)
        table = tabletop_scene(rng, np.array([first, first + 3.0, first + rng.uniform(40.0, 120.0)]))
        centres, boxes, poses = table.centres_base, table.boxes_xyxy, table.T_base_optical
        boxes = perturb_boxes(boxes.reshape(-1, 4), sigma, rng).reshape(boxes.shape) if sigma > 0 else boxes
        orders = [rng.permutation(len(centres)) for _ in poses]  # pooled: the order says nothing
        views = tuple(View(T, tuple(Detection(b) for b in B[o])) for T, B, o in zip(poses, boxes, orders))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = mv.localize(Session(CAMERA, views), **{"size_range": SIZE_RANGE_M, **options})
        for obj in result.objects:
            held = [obj.associations.get(k, -1) for k in range(len(poses))]
            owners = {int(o[j]) for o, j in zip(orders, held) if j >= 0}
            mixed += len(owners) > 1
        missed += int(np.isnan(errors_mm(result.positions.reshape(-1, 3), centres)).sum())
    n = len(seeds) * (N_LYING + N_BOTTLES)
    print(
        f"two viewpoints, seeds {seeds.start}-{seeds.stop - 1}: estimates with boxes of two objects {mixed}, missed {missed}/{n}"
    )


def main(seeds: range, sigma: float, options: dict, cuboids: bool = False) -> None:
    all_views, subsets, bad = [], [], 0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        table = tabletop_scene(rng, cuboids=cuboids)
        centres, boxes, poses = table.centres_base, table.boxes_xyxy, table.T_base_optical
        boxes = perturb_boxes(boxes.reshape(-1, 4), sigma, rng).reshape(boxes.shape) if sigma > 0 else boxes
        for subset in itertools.chain([tuple(range(N_VIEWS))], itertools.combinations(range(N_VIEWS), SUBSET)):
            views = []
            for k in subset:
                order = rng.permutation(len(centres))  # pooled: the order says nothing
                views.append(View(poses[k], tuple(Detection(b) for b in boxes[k][order])))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = mv.localize(Session(CAMERA, tuple(views)), **{"size_range": SIZE_RANGE_M, **options})
            e = errors_mm(result.positions.reshape(-1, 3), centres)
            (all_views if len(subset) == N_VIEWS else subsets).append(e)
            bad += len(subset) == SUBSET and bool(np.isnan(e).any())
    a, s = np.array(all_views).ravel(), np.array(subsets).ravel()
    print(
        f"seeds {seeds.start}-{seeds.stop - 1} noise {sigma:g}{' cuboids' if cuboids else ''}: 8 views mean {np.nanmean(a):.1f} max {np.nanmax(a):.1f} mm, "
        f"missed {int(np.isnan(a).sum())}/{len(a)} | 3-view subsets mean {np.nanmean(s):.1f} median {np.nanmedian(s):.1f} "
        f"p90 {np.nanpercentile(s, 90):.1f} mm, missed {int(np.isnan(s).sum())}/{len(s)}, subsets with a miss {bad}/"
        f"{len(subsets)}"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        epilog="Options to localize go after --, as KEY=VALUE (values read as JSON where they parse), e.g. -- second_look=false.",
    )
    parser.add_argument("first", nargs="?", type=int, default=800, help="first seed (default 800)")
    parser.add_argument("last", nargs="?", type=int, default=805, help="last seed, excluded (default 805)")
    parser.add_argument("noise", nargs="?", type=float, default=0.01, help="box noise, relative (default 0.01)")
    parser.add_argument("--two-viewpoints", action="store_true", help="two views 3 degrees apart and a third (two_viewpoints)")
    parser.add_argument("--cuboids", action="store_true", help="the lying objects are cuboids, not ellipsoids")
    try:
        own, localize_options = split_options(sys.argv[1:])
    except InputError as exc:
        parser.error(str(exc))
    args = parser.parse_intermixed_args(own)
    seed_range = range(args.first, args.last)
    if args.two_viewpoints:
        two_viewpoints(seed_range, args.noise, localize_options)
    else:
        main(seed_range, args.noise, localize_options, cuboids=args.cuboids)
