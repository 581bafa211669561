"""A table top of lying boxes and upright bottles, 8 views from one side and every 3 of them: which pairings survive.

A simulated counterpart of a real multi-view table-top set (Aldoma's, ``monovisual3d bench real``), drawn afresh per
seed: four objects lying on the table (ellipsoids 240 x 110 x 120 mm, random yaw: the shape stage's yawed ellipsoid,
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

Usage: python benchmarks/tabletop_subsets.py [FIRST_SEED LAST_SEED] [NOISE] [--two-viewpoints] [--cuboids] [-- key=value ...]
(LAST_SEED excluded; default seeds 800-804, noise 0.01; ``--two-viewpoints``: :func:`two_viewpoints` instead; options
after ``--`` go to ``localize``, values read as JSON where they parse; ``--cuboids``: the lying objects are boxes, cuboids
of the same half-sides, as real boxes are).
"""

import itertools
import sys
import warnings
from functools import partial

import numpy as np
from container_pairs import errors_mm as container_errors_mm
from option_ab import split_options

import monovisual3d as mv
from monovisual3d.camera import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.ellipsoid import ellipsoid_bbox
from monovisual3d.geometry.orientation import rotation_upright
from monovisual3d.geometry.solids import cuboid_bbox, cylinder_bbox
from monovisual3d.session import Detection, Session, View
from monovisual3d.sim.noise import perturb_boxes

CAMERA = Camera(640, 480, 528.0, 528.0, 319.5, 239.5)
#: Lying objects' semi-axes and bottles' radius and half-height (metres); how many of each.
BOX_HALF_SIDES_M, BOTTLE_R_M, BOTTLE_HALF_H_M = (0.12, 0.055, 0.06), 0.04, 0.09
N_BOXES, N_BOTTLES = 4, 2
#: Objects' centres lie in a square of this half-side (metres); their footprints (circles of these radii, metres) do not
#: overlap.
HALF_TABLE_M = 0.3
BOX_FOOTPRINT_M, BOTTLE_FOOTPRINT_M = float(np.hypot(*BOX_HALF_SIDES_M[:2])), BOTTLE_R_M
#: Views: azimuths uniform over this arc (degrees), distance (metres) and elevation (degrees) ranges, aim jitter (metres).
ARC_DEG, DISTANCE_M, ELEVATION_DEG, AIM_JITTER_M = 180.0, (0.9, 1.1), (35.0, 40.0), 0.03
N_VIEWS, SUBSET = 8, 3
FOUND_M = 0.05
SIZE_RANGE_M = (0.02, 0.15)


def scene(
    rng: np.random.Generator, azimuths_deg: np.ndarray | None = None, cuboids: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres (N, 3), exact boxes (views, N, 4) and poses (views, 4, 4) of one table top whose boxes all lie inside
    the images, seen from ``N_VIEWS`` random azimuths or from ``azimuths_deg``; the lying objects cuboids of the same
    half-sides with ``cuboids`` (the same draws)."""
    while True:
        centres: list[np.ndarray] = []
        reach = [BOX_FOOTPRINT_M] * N_BOXES + [BOTTLE_FOOTPRINT_M] * N_BOTTLES
        while len(centres) < N_BOXES + N_BOTTLES:
            xy, r = rng.uniform(-HALF_TABLE_M, HALF_TABLE_M, 2), reach[len(centres)]
            if all(np.hypot(*(xy - c[:2])) >= r + r_c for c, r_c in zip(centres, reach)):
                z = BOX_HALF_SIDES_M[2] if len(centres) < N_BOXES else BOTTLE_HALF_H_M
                centres.append(np.array([xy[0], xy[1], z]))
        poses = []
        if azimuths_deg is None:
            azimuths = np.sort(rng.uniform(-np.radians(ARC_DEG) / 2, np.radians(ARC_DEG) / 2, N_VIEWS))
        else:
            azimuths = np.radians(azimuths_deg)
        for az in azimuths:
            d, e = rng.uniform(*DISTANCE_M), np.radians(rng.uniform(*ELEVATION_DEG))
            eye = d * np.array([-np.cos(e) * np.cos(az), np.cos(e) * np.sin(az), np.sin(e)])
            poses.append(look_at(eye, rng.uniform(-AIM_JITTER_M, AIM_JITTER_M, 3)))
        T = np.array(poses)
        lying = cuboid_bbox if cuboids else partial(ellipsoid_bbox, clip=False)
        boxes = [lying(CAMERA, T, c, BOX_HALF_SIDES_M, rotation_upright(rng.uniform(0, np.pi))) for c in centres[:N_BOXES]]
        boxes += [cylinder_bbox(CAMERA, T, c, BOTTLE_R_M, BOTTLE_HALF_H_M, rotation_upright(0.0)) for c in centres[N_BOXES:]]
        B = np.stack(boxes, axis=1)
        if np.all(B[..., :2] >= 0) and np.all(B[..., 2] <= CAMERA.width) and np.all(B[..., 3] <= CAMERA.height):
            return np.array(centres), B, T


def errors_mm(estimates: np.ndarray, centres: np.ndarray) -> list[float]:
    """Per object, the distance (mm) to its Hungarian-paired estimate, NaN when missed (beyond ``FOUND_M``)."""
    return container_errors_mm(estimates, centres, FOUND_M)


def two_viewpoints(seeds: range, sigma: float, options: dict) -> None:
    """Three views of which two stand 3 degrees of azimuth apart (their distances and elevations drawn apart: 4-22 cm,
    median 8 cm) and the third 40-120 degrees away, one run per seed: the objects each estimate takes its boxes from,
    against the truth."""
    mixed = missed = 0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        first = rng.uniform(-90.0, 30.0)
        centres, boxes, poses = scene(rng, np.array([first, first + 3.0, first + rng.uniform(40.0, 120.0)]))
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
    n = len(seeds) * (N_BOXES + N_BOTTLES)
    print(
        f"two viewpoints, seeds {seeds.start}-{seeds.stop - 1}: estimates with boxes of two objects {mixed}, missed {missed}/{n}"
    )


def main(seeds: range, sigma: float, options: dict, cuboids: bool = False) -> None:
    all_views, subsets, bad = [], [], 0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        centres, boxes, poses = scene(rng, cuboids=cuboids)
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
    args, options = split_options(sys.argv[1:], "tabletop_subsets.py")
    flags = ("--two-viewpoints", "--cuboids")
    run = two_viewpoints if "--two-viewpoints" in args else partial(main, cuboids="--cuboids" in args)
    args = [a for a in args if a not in flags]
    run(
        range(int(args[0]), int(args[1])) if len(args) > 1 else range(800, 805),
        float(args[2]) if len(args) > 2 else 0.01,
        options,
    )
