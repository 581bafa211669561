"""What a wrong image size costs: a container cut by the image's right border, with the image taken as twice the
principal point.

An LfD folder has no image size (``monovisual3d import-lfd``); a calibrated principal point lies a few pixels off the
image centre, so twice the principal point is not the image size. Where the border is assumed decides which box edges
count as truncated (one-sided). Simulated: a 50 x 50 x 120 mm upright ellipsoid container, three views over 120 degrees
at 0.5-0.7 m (:func:`monovisual3d.sim.containers.arc_views`), view 0 turned so that the container straddles its right border,
1280 x 720, 0.5 % box noise, the boxes clipped to the true image. The default ``localize`` runs once with the true image
size and once with the image taken as twice the principal point, for the principal point ``DCX`` px right of centre (and
half that below).

Printed per offset: the mean and max error (mm) of the nearest estimate with each image size, and the runs without one.

Usage: python experiments/image_border.py [FIRST LAST] [DCX ...]   (default: seeds 0-19, offsets -8 and 8 px)
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

import monovisual3d as mv
from monovisual3d.camera import Camera
from monovisual3d.geometry.ellipsoid import Ellipsoid
from monovisual3d.session import Detection, Session, View
from monovisual3d.sim.containers import arc_views, arm_camera, scene_middle
from monovisual3d.sim.noise import perturb_boxes

#: Container semi-axes (metres), box noise, the turn of view 0 about its y axis (radians: the container's image then
#: crosses the right border of a 69-degree, 1280 px wide view).
SEMI_AXES_M, NOISE, TURN_RAD = np.array([0.025, 0.025, 0.06]), 0.005, (0.55, 0.62)


def errors_mm(dcx: float, seeds: range) -> dict[str, np.ndarray]:
    """Per seed, the error (mm, NaN: no estimate) with the true image size and with twice the principal point."""
    nominal = arm_camera()
    true = Camera(1280, 720, nominal.fx, nominal.fy, nominal.cx + dcx, nominal.cy + 0.5 * dcx)
    assumed = Camera(round(2 * true.cx), round(2 * true.cy), true.fx, true.fy, true.cx, true.cy)
    out: dict[str, list[float]] = {"true size": [], "twice the principal point": []}
    for seed in seeds:
        rng = np.random.default_rng(seed)
        centre = scene_middle(rng)
        poses = arc_views(3, rng.uniform(0.0, 30.0), centre, rng)
        t = rng.uniform(*TURN_RAD)
        poses[0, :3, :3] = poses[0, :3, :3] @ np.array([[np.cos(t), 0, -np.sin(t)], [0, 1, 0], [np.sin(t), 0, np.cos(t)]])
        box = Ellipsoid(centre, SEMI_AXES_M, np.array([0.0, 0.0, 0.0, 1.0])).bbox(true, poses, clip=False)
        box = np.clip(perturb_boxes(box, NOISE, rng), 0.0, [1280, 720, 1280, 720])
        for key, cam in zip(out, (true, assumed)):
            session = Session(cam, tuple(View(T, (Detection(b),)) for T, b in zip(poses, box)))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = mv.localize(session)
            d = np.linalg.norm(result.positions - centre, axis=1) if len(result.objects) else [np.nan]
            out[key].append(1e3 * float(np.min(d)))
    return {k: np.array(v) for k, v in out.items()}


def main(first: int, last: int, offsets: list[float]) -> None:
    seeds = range(first, last)
    for dcx in offsets or [-8.0, 8.0]:
        parts = []
        for key, e in errors_mm(dcx, seeds).items():
            f = e[np.isfinite(e)]
            parts.append(f"{key}: mean {f.mean():.1f} max {f.max():.1f} mm, none {int(np.isnan(e).sum())}")
        print(f"principal point {dcx:+g} px, seeds {seeds.start}-{seeds.stop - 1}: " + " | ".join(parts))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("first", nargs="?", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("last", nargs="?", type=int, default=20, help="last seed, excluded (default 20)")
    parser.add_argument("dcx", nargs="*", type=float, help="principal point offsets, px (default -8 8)")
    args = parser.parse_args()
    main(args.first, args.last, args.dcx)
