"""Is a hand-eye calibration's error determined by the boxes? A least-squares check on the objects' centres.

A hand-eye error is one rigid motion ``E`` of the camera in its own frame, the same in every view
(``T_base_optical_reported = T_base_optical @ E``; ``container_pairs.py --hand-eye-error``). This script takes the
containers-and-tray scene's three centres (two containers 57 mm apart and the tray, ``container_pairs.py``), its 8
views at one elevation (``solid_shape_bias.views``), projects the centres with the true poses (plus Gaussian pixel
noise), and estimates the centres from the reported poses by least squares on the projections:

- ``plain``: the centres alone (as every method does: poses taken as given);
- ``joint``: the centres and ``E`` together (6 more unknowns, no prior).

Printed: the centres' error (mm) of each, mean / median / p90 over seeds and objects. With exact projections the joint
fit recovers ``E``; with 1 px of noise it is far off (the boxes do not determine ``E``), while the plain fit's error is
the bias ``E`` leaves. Centres only: box sizes, which also carry depth, are left out.

Usage::

    python benchmarks/hand_eye_bias.py [ELEVATION_DEG MM DEG VIEWS NOISE_PX SEEDS]   # default 10 1 0.3 8 1 200
"""

import sys

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation
from solid_shape_bias import CAMERAS, TARGET, views

from monovisual3d.frames import invert_transform, transform_points
from monovisual3d.sim.noise import perturb_pose

#: The scene's centres relative to the middle of the pair, metres: the two containers and the tray
#: (``container_pairs.SPACING_M``, ``TRAY_OFFSET_M``).
OFFSETS_M = np.array([[0.0, -0.0285, 0.0], [0.0, 0.0285, 0.0], [0.07, 0.0, -0.045]])


def project(T_base_optical: np.ndarray, p_base: np.ndarray) -> np.ndarray:
    """Pixel offsets from the principal point (N, 2) of base-frame points (N, 3) in a 1280 x 720, 69-degree view."""
    p = transform_points(invert_transform(T_base_optical), p_base)
    return CAMERAS["1280x720"].fx * p[:, :2] / p[:, 2:3]


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
        centres = TARGET + rng.uniform(-0.01, 0.01, 3) + OFFSETS_M
        poses = views(rng, 8, elevation, centres[:2].mean(axis=0))
        poses = poses[np.sort(rng.choice(8, n_views, replace=False))]
        reported = poses @ perturb_pose(np.eye(4), 1e-3 * mm, np.radians(deg), rng)
        seen = np.stack([project(T, centres) for T in poses]) + rng.normal(0.0, noise_px, (n_views, 3, 2))
        start = centres.ravel()
        for name, joint in (("plain", False), ("joint", True)):
            fit = least_squares(residuals, np.r_[start, np.zeros(6 * joint)], x_scale=0.01, args=(reported, seen, joint))
            errors[name].append(1e3 * np.linalg.norm(fit.x[:9].reshape(3, 3) - centres, axis=1))
            start = fit.x[:9]
    for name, e in errors.items():
        a = np.concatenate(e)
        print(f"{name}: mean {a.mean():.2f} median {np.median(a):.2f} p90 {np.percentile(a, 90):.2f} mm")


if __name__ == "__main__":
    args = [float(a) for a in sys.argv[1:]] + [10, 1, 0.3, 8, 1, 200][len(sys.argv) - 1 :]
    main(args[0], args[1], args[2], int(args[3]), args[4], int(args[5]))
