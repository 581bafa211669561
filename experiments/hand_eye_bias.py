"""Is a hand-eye calibration's error determined by the boxes? A least-squares check on the objects' centres.

A hand-eye error is one rigid motion ``E`` of the camera in its own frame, the same in every view
(``T_base_optical_reported = T_base_optical @ E``; ``experiments/container_pairs.py --hand-eye-error``). This script
takes the containers-and-tray scene's three centres (two containers 57 mm apart and the tray,
:mod:`monovisual3d.sim.containers`), its 8 views at one elevation (:func:`~monovisual3d.sim.containers.arc_views`), projects the centres with the true poses (plus Gaussian pixel
noise), and estimates the centres from the reported poses by least squares on the projections:

- ``plain``: the centres alone (as every method does: poses taken as given);
- ``joint``: the centres and ``E`` together (6 more unknowns, no prior).

Printed: the centres' error (mm) of each, mean / median / p90 over seeds and objects. With exact projections the joint
fit recovers ``E``; with 1 px of noise it is far off (the boxes do not determine ``E``), while the plain fit's error is
the bias ``E`` leaves. Centres only: box sizes, which also carry depth, are left out.

Usage::

    python experiments/hand_eye_bias.py [ELEVATION_DEG MM DEG VIEWS NOISE_PX SEEDS]   # default 10 1 0.3 8 1 200
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from monovisual3d.frames import invert_transform, transform_points
from monovisual3d.sim.containers import SPACING_M, TRAY_OFFSET_M, arc_views, arm_camera, scene_middle
from monovisual3d.sim.noise import hand_eye_offset

#: The scene's centres relative to the middle of the pair, metres: the two containers and the tray.
OFFSETS_M = np.array([[0.0, -SPACING_M / 2, 0.0], [0.0, SPACING_M / 2, 0.0], TRAY_OFFSET_M])
#: Views of the scene (as ``experiments/container_pairs.py``); a run uses VIEWS of them, chosen at random.
ALL_VIEWS = 8
CAMERA = arm_camera()


def project(T_base_optical: np.ndarray, p_base: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) of base-frame points (N, 3) in the scene's 1280 x 720, 69-degree camera."""
    return CAMERA.project(transform_points(invert_transform(T_base_optical), p_base))


def correction(x: np.ndarray) -> np.ndarray:
    """The rigid motion (4, 4) of a 6-vector: translation (metres) then rotation vector (radians)."""
    E = np.eye(4)
    E[:3, :3], E[:3, 3] = Rotation.from_rotvec(x[3:]).as_matrix(), x[:3]
    return E


def residuals(x: np.ndarray, reported: np.ndarray, seen: np.ndarray, joint: bool) -> np.ndarray:
    """Projection residuals (pixels) of centres ``x[:9]`` (and, ``joint``, the correction ``x[9:]``)."""
    E = correction(x[9:]) if joint else np.eye(4)
    return np.concatenate([(project(T @ E, x[:9].reshape(3, 3)) - s).ravel() for T, s in zip(reported, seen)])


def main(elevation: float, mm: float, deg: float, n_views: int, noise_px: float, n_seeds: int) -> None:
    errors: dict[str, list[np.ndarray]] = {"plain": [], "joint": []}
    for seed in range(n_seeds):
        rng = np.random.default_rng(seed)
        centres = scene_middle(rng) + OFFSETS_M
        poses = arc_views(ALL_VIEWS, elevation, centres[:2].mean(axis=0), rng)
        poses = poses[np.sort(rng.choice(ALL_VIEWS, n_views, replace=False))]
        reported = poses @ hand_eye_offset(1e-3 * mm, np.radians(deg), rng)
        seen = np.stack([project(T, centres) for T in poses]) + rng.normal(0.0, noise_px, (n_views, 3, 2))
        start = centres.ravel()
        for name, joint in (("plain", False), ("joint", True)):
            fit = least_squares(residuals, np.r_[start, np.zeros(6 * joint)], x_scale=0.01, args=(reported, seen, joint))
            errors[name].append(1e3 * np.linalg.norm(fit.x[:9].reshape(3, 3) - centres, axis=1))
            start = fit.x[:9]
    for name, e in errors.items():
        a = np.concatenate(e)
        print(f"{name}: mean {a.mean():.2f} median {np.median(a):.2f} p90 {np.percentile(a, 90):.2f} mm")


def _arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("elevation", nargs="?", type=float, default=10.0, help="degrees (default 10)")
    parser.add_argument("mm", nargs="?", type=float, default=1.0, help="hand-eye position error, mm per axis (default 1)")
    parser.add_argument("deg", nargs="?", type=float, default=0.3, help="hand-eye rotation error, degrees per axis (0.3)")
    parser.add_argument("views", nargs="?", type=int, default=8, help=f"views per run, 2-{ALL_VIEWS} (default 8)")
    parser.add_argument("noise_px", nargs="?", type=float, default=1.0, help="pixel noise of the projections (default 1)")
    parser.add_argument("seeds", nargs="?", type=int, default=200, help="seeds 0..SEEDS-1 (default 200)")
    a = parser.parse_args()
    values = (a.elevation, a.mm, a.deg, a.noise_px)
    if not all(np.isfinite(values)) or min(values[1:]) < 0 or not 2 <= a.views <= ALL_VIEWS or a.seeds < 1:
        parser.error(f"expected numbers >= 0, VIEWS 2-{ALL_VIEWS}, SEEDS >= 1; got {vars(a)}")
    return a


if __name__ == "__main__":
    args = _arguments()
    main(args.elevation, args.mm, args.deg, args.views, args.noise_px, args.seeds)
