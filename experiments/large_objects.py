"""Single large objects of random shape, pose and viewpoints: how far the default method puts their centres.

One object per seed, its kind by the seed (seed % 4: cuboid, upright cylinder, sphere, yawed ellipsoid), half of them
flat (a 10-30 mm half-thickness; ellipsoids 15-40 mm); sizes 50-150 mm (half-sides, radius, semi-axes), a random yaw;
2-5 views over 40-180 degrees of azimuth, each 0.5-1.2 m away and 0-80 degrees above, aimed within 3 cm of it; 1280 x
720 (69 degrees wide); box noise 0.5-3 % (:func:`monovisual3d.sim.noise.perturb_boxes`). The default ``localize`` with
``size_range=(0.02, 0.15)`` and ``reach=1.0``; the estimate nearest the truth is scored.

Printed per kind: runs, mean / p90 centre error (mm), runs with no estimate, and how many came out as each solid (a
sphere taken for a solid is the wrong model); then the median and p90 runtime (s).

Usage::

    python experiments/large_objects.py [FIRST LAST] [-- key=value ...]   # seeds FIRST..LAST-1, default 0 200

Options after ``--`` go to ``localize`` (values read as JSON where they parse), e.g. ``solids=false``.

What it showed (2026-12-05, seeds 0-199, 50 of each kind; before = 3842c04, run at the same time on the other core),
before -> after large objects were fitted with every model (``shapes.LARGE_RADIUS_M``), mean / p90 centre error:
cuboids 19.8 / 39.5 -> 7.9 / 15.9 mm (as cuboids 12 -> 37 of 50), cylinders 8.7 / 17.4 -> 6.6 / 12.8 mm (as cylinders
20 -> 42), spheres 5.3 / 10.4 mm either way (none taken for a solid), ellipsoids 6.7 / 14.6 -> 6.5 / 12.6 mm (taken for
solids 1 -> 5); 5 runs with no estimate either way; runtime median 0.143 -> 0.160 s.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections import Counter

import numpy as np

import monovisual3d as mv
from monovisual3d.bench.option_ab import split_options
from monovisual3d.camera import Camera
from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.geometry.ellipsoid import ellipsoid_bbox
from monovisual3d.geometry.orientation import rotation_upright
from monovisual3d.geometry.solids import cuboid_bbox, cylinder_bbox
from monovisual3d.session import Detection, Session, View
from monovisual3d.sim.noise import perturb_boxes

CAMERA = Camera.from_hfov(1280, 720, 69.0)
KINDS = ("cuboid", "cylinder", "sphere", "ellipsoid")
#: Sizes (metres): half-sides, radius, semi-axes; a flat object's half-thickness (an ellipsoid's a little more).
SIZE_M, FLAT_M, FLAT_ELLIPSOID_M = (0.05, 0.15), (0.01, 0.03), (0.015, 0.04)
#: Views: how many, their azimuth span (degrees), distance (metres), elevation (degrees), aim jitter (metres).
N_VIEWS, SPAN_DEG, DISTANCE_M, ELEVATION_DEG, AIM_JITTER_M = (2, 5), (40.0, 180.0), (0.5, 1.2), (0.0, 80.0), 0.03
BOX_NOISE = (0.005, 0.03)


def scene(seed: int) -> tuple[str, Session, np.ndarray]:
    """The kind, the session (one box per view) and the true centre (3,) of one seed's object."""
    rng = np.random.default_rng(seed)
    kind, flat = KINDS[seed % len(KINDS)], bool(rng.random() < 0.5)
    centre = rng.uniform(-0.05, 0.05, 3)
    R = rotation_upright(rng.uniform(0.0, np.pi))
    if kind in ("cuboid", "ellipsoid"):
        size = rng.uniform(*SIZE_M, 3)
        size[2] = rng.uniform(*(FLAT_M if kind == "cuboid" else FLAT_ELLIPSOID_M)) if flat else size[2]
    else:
        r = rng.uniform(*SIZE_M)
        half_height = rng.uniform(*FLAT_M) if flat else rng.uniform(*SIZE_M)
    azimuths = rng.uniform(0.0, 2 * np.pi) + np.linspace(
        0.0, np.radians(rng.uniform(*SPAN_DEG)), rng.integers(*N_VIEWS, endpoint=True)
    )
    poses = []
    for az in azimuths:
        e, d = np.radians(rng.uniform(*ELEVATION_DEG)), rng.uniform(*DISTANCE_M)
        eye = centre + d * np.array([np.cos(e) * np.cos(az), np.cos(e) * np.sin(az), np.sin(e)])
        poses.append(look_at(eye, centre + rng.uniform(-AIM_JITTER_M, AIM_JITTER_M, 3)))
    T = np.array(poses)
    if kind == "cuboid":
        boxes = cuboid_bbox(CAMERA, T, centre, size, R)
    elif kind == "cylinder":
        boxes = cylinder_bbox(CAMERA, T, centre, r, half_height, R)
    elif kind == "sphere":
        boxes = ellipsoid_bbox(CAMERA, T, centre, [r, r, r], np.eye(3), clip=False)
    else:
        boxes = ellipsoid_bbox(CAMERA, T, centre, size, R, clip=False)
    boxes = perturb_boxes(np.asarray(boxes).reshape(-1, 4), rng.uniform(*BOX_NOISE), rng)
    return kind, Session(CAMERA, tuple(View(t, (Detection(b),)) for t, b in zip(T, boxes))), centre


def main(seeds: range, options: dict) -> None:
    errors: dict[str, list[float]] = {k: [] for k in KINDS}
    solids: dict[str, Counter] = {k: Counter() for k in KINDS}
    times = []
    for seed in seeds:
        kind, session, centre = scene(seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            result = mv.localize(session, **{"size_range": (0.02, 0.15), "reach": 1.0, **options})
            times.append(time.perf_counter() - t0)
        if not result.objects:
            errors[kind].append(float("nan"))
            continue
        d = np.linalg.norm(result.positions.reshape(-1, 3) - centre, axis=1)
        errors[kind].append(1e3 * float(d.min()))
        solids[kind][result.objects[int(d.argmin())].extra.get("solid") or "none"] += 1
    print(f"seeds {seeds.start}-{seeds.stop - 1}{' ' + str(options) if options else ''}")
    for kind in KINDS:
        e = np.array(errors[kind])
        if not len(e):
            continue
        found = e[np.isfinite(e)]
        stats = f"mean {np.mean(found):.1f} p90 {np.percentile(found, 90):.1f} mm" if len(found) else "nothing found"
        print(f"  {kind}: {len(e)} runs, {stats}, no estimate {int(np.isnan(e).sum())}, solids {dict(solids[kind])}")
    print(f"  runtime median {np.median(times):.3f} s, p90 {np.percentile(times, 90):.3f} s")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        epilog="Options to localize go after --, as KEY=VALUE (values read as JSON where they parse), e.g. -- solids=false.",
    )
    parser.add_argument("first", nargs="?", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("last", nargs="?", type=int, default=200, help="last seed, excluded (default 200)")
    try:
        own, localize_options = split_options(sys.argv[1:])
    except InputError as exc:
        parser.error(str(exc))
    args = parser.parse_args(own)
    main(range(args.first, args.last), localize_options)
