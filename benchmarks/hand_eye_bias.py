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
from container_pairs import SPACING_M, TRAY_OFFSET_M
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation
from solid_shape_bias import CAMERAS, TARGET, views

from monovisual3d.frames import invert_transform, transform_points
from monovisual3d.sim.noise import hand_eye_offset

#: The scene's centres relative to the middle of the pair, metres: the two containers and the tray.
OFFSETS_M = np.array([[0.0, -SPACING_M / 2, 0.0], [0.0, SPACING_M / 2, 0.0], TRAY_OFFSET_M])
#: Views of the scene (``container_pairs.N_VIEWS``); a run uses VIEWS of them, chosen at random.
ALL_VIEWS = 8


def project(T_base_optical: np.ndarray, p_base: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) of base-frame points (N, 3) in the scene's 1280 x 720, 69-degree camera."""
    return CAMERAS["1280x720"].project(transform_points(invert_transform(T_base_optical), p_base))


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
        poses = views(rng, ALL_VIEWS, elevation, centres[:2].mean(axis=0))
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


def _arguments(argv: list[str]) -> tuple[float, float, float, int, float, int]:
    """``ELEVATION_DEG MM DEG VIEWS NOISE_PX SEEDS`` (defaults for those left out); exits with one line on bad ones."""
    usage = "hand_eye_bias.py: expected [ELEVATION_DEG MM DEG VIEWS NOISE_PX SEEDS], numbers >= 0, VIEWS 2-8, SEEDS >= 1"
    try:
        a = [float(x) for x in argv] + [10.0, 1.0, 0.3, 8.0, 1.0, 200.0][len(argv) :]
    except ValueError:
        sys.exit(f"{usage}; got {argv}")
    if len(a) != 6 or not all(np.isfinite(a)) or min(a[1:]) < 0 or not 2 <= a[3] <= ALL_VIEWS or a[5] < 1:
        sys.exit(f"{usage}; got {argv}")
    return a[0], a[1], a[2], int(a[3]), a[4], int(a[5])


if __name__ == "__main__":
    main(*_arguments(sys.argv[1:]))
