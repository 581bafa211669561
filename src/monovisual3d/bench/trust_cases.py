"""The clean sessions of ``bench trust``: scene families, views and cameras, drawn from a seed.

Four families, each a kind of session a robot records:

- ``paper``: the paper's six spheres, seen from the paper's three poses or a ring of 4-5 views (ideal camera,
  640x480, 69 degrees);
- ``greenhouse``: a tomato truss with leaves, from the paper's three poses or an arc of 4-5 views (ideal camera);
- ``arc``: 6-8 random fruit, 5-8 views along a horizontal arc of 50-70 degrees, taken at
  :data:`FRAME_RATE_HZ` (so that poses can be a frame late), a 960x540 camera with lens distortion;
- ``row``: 6-8 random fruit, 5-8 views along a straight row of 0.3-0.4 m, at the same rate, the same
  kind of camera.

Boxes carry the simulator's relative box noise (:data:`BOX_NOISES`: 2, 5 and 10 %); poses are exact (the
mistakes are what is wrong with them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from ..session import Session
from ..sim.mistakes import MistakeInputs
from ..sim.motion import FrameTimes, frame_times
from ..sim.noise import NoiseModel
from ..sim.scenes import default_camera, greenhouse_scene, paper_scene, random_scene, scene_target
from ..sim.simulate import simulate
from ..sim.viewpoints import arc_poses, paper_poses, ring_poses, row_poses

#: The scene families, in the order the seeds cycle through them.
FAMILIES = ("paper", "greenhouse", "arc", "row")
#: Box noise levels of the clean sessions (std relative to the box size).
BOX_NOISES = (0.02, 0.05, 0.10)
#: Frame rate of the views along arcs and rows, Hz: one frame late is one view's spacing.
FRAME_RATE_HZ = 5.0
#: The arc and row families' image size (16:9, so that a centre crop is 4:3 of it) and field of view.
PATH_IMAGE_SIZE = (960, 540)
PATH_HFOV_DEG = 75.0
#: Ranges the lens distortion of the arc and row cameras is drawn from (OpenCV plumb_bob, a barrel lens):
#: k1, k2, p1, p2, k3. A draw whose model folds inside the image (:func:`distortion_folds`) is drawn again.
DISTORTION_RANGES = ((-0.3, -0.1), (0.02, 0.12), (-0.002, 0.002), (-0.002, 0.002), (-0.05, 0.05))
#: Draws of the distortion before giving up, and the round trip (pixels) that tells a model that folds.
MAX_DISTORTION_DRAWS = 100
FOLD_TOLERANCE_PX = 1e-3
#: Points per image side where the round trip is checked.
FOLD_CHECK_POINTS = 33
#: Distance of the row cameras to the fruit's centre plane, metres, and the half extent (depth, along, up) of the
#: box the row's random fruit fill.
ROW_DISTANCE_M = 0.6
ROW_FRUIT_HALF_EXTENT = (0.08, 0.18, 0.12)


@dataclass(frozen=True)
class TrustCase:
    """One clean session of the bench and what a mistake or a score needs of it.

    Attributes
    ----------
    family : str, one of :data:`FAMILIES`
    seed : int
    box_sigma : float, the box noise
    session : Session, the clean session
    frames : FrameTimes or None, the views as frames along a path with the pose stream (arc and row)
    centres : ndarray, shape (K, 3), metres, base frame, the true fruit centres
    radii : ndarray, shape (K,), metres
    views : str, how the views were placed (``paper``, ``ring:5``, ``arc:6:60``, ``row:7:0.35``)
    """

    family: str
    seed: int
    box_sigma: float
    session: Session
    frames: FrameTimes | None
    centres: NDArray[np.float64]
    radii: NDArray[np.float64]
    views: str

    def inputs(self) -> MistakeInputs:
        """What the mistakes of :mod:`monovisual3d.sim.mistakes` start from."""
        return MistakeInputs(self.session.to_dict(), self.frames)

    def describe(self) -> dict[str, Any]:
        """The case in plain JSON values."""
        return {
            "family": self.family,
            "seed": self.seed,
            "box_sigma": self.box_sigma,
            "views": self.views,
            "n_views": len(self.session.views),
            "n_fruit": len(self.centres),
            "camera": f"{self.session.camera.width}x{self.session.camera.height}"
            + ("" if self.session.camera.distortion_model == "none" else " distorted"),
        }


def case_rng(family: str, seed: int, box_sigma: float) -> np.random.Generator:
    """The generator a case draws from: one stream per (family, seed, noise level)."""
    return np.random.default_rng((int(seed), FAMILIES.index(family), round(1000 * box_sigma)))


def make_case(family: str, seed: int, box_sigma: float) -> TrustCase:
    """The clean session of ``family`` for ``seed`` at box noise ``box_sigma`` (see the module docstring)."""
    if family not in FAMILIES:
        raise ValueError(f"family: got {family!r}, expected one of {FAMILIES}")
    rng = case_rng(family, seed, box_sigma)
    frames = None
    if family == "paper":
        scene, camera = paper_scene(), default_camera()
        n = int(rng.choice([3, 4, 5]))
        poses = paper_poses(scene_target(scene)) if n == 3 else ring_poses(scene_target(scene), n)
        views = "paper" if n == 3 else f"ring:{n}"
    elif family == "greenhouse":
        camera = default_camera()
        n = int(rng.choice([3, 4, 5]))
        span = math.radians(50.0)
        poses = paper_poses() if n == 3 else arc_poses(n=n, span=span)
        scene = greenhouse_scene(rng, camera=camera, poses=poses)
        views = "paper" if n == 3 else f"arc:{n}:50"
    else:
        camera = path_camera(rng)
        scene, views, path, n = _path_scene(family, rng)
        poses = path(np.arange(n, dtype=float))
        frames = frame_times(path, n, FRAME_RATE_HZ)
    session, _ = simulate(scene, camera, poses, noise=NoiseModel(box_sigma=box_sigma), rng=rng, frames=frames)
    return TrustCase(family, seed, box_sigma, session, frames, scene.centres, scene.radii, views)


def path_camera(rng: np.random.Generator) -> Camera:
    """The arc and row families' camera: :data:`PATH_IMAGE_SIZE`, :data:`PATH_HFOV_DEG`, distortion drawn in
    :data:`DISTORTION_RANGES` until it does not fold inside the image."""
    ideal = Camera.from_hfov(*PATH_IMAGE_SIZE, PATH_HFOV_DEG)
    for _ in range(MAX_DISTORTION_DRAWS):
        coeffs = tuple(float(rng.uniform(lo, hi)) for lo, hi in DISTORTION_RANGES)
        camera = Camera(ideal.width, ideal.height, ideal.fx, ideal.fy, ideal.cx, ideal.cy, "plumb_bob", coeffs)
        if not distortion_folds(camera):
            return camera
    raise ValueError(f"DISTORTION_RANGES: no draw in {MAX_DISTORTION_DRAWS} that keeps the lens model one-to-one")


def distortion_folds(camera: Camera) -> bool:
    """Whether the lens model folds inside the image: a pixel whose undistorted ray does not project back to it.

    A polynomial model (a negative ``k3``) turns back at some radius; pixels beyond it are seen by no ray, and the
    fixed-point undistortion diverges there. No real lens does that inside its own image.
    """
    u, v = np.meshgrid(np.linspace(0, camera.width, FOLD_CHECK_POINTS), np.linspace(0, camera.height, FOLD_CHECK_POINTS))
    uv = np.stack([u, v], axis=-1).reshape(-1, 2)
    back = camera.pixels_from_normalised(camera.distort(camera.undistort(camera.normalised_from_pixels(uv))))
    return not bool(np.all(np.abs(back - uv) < FOLD_TOLERANCE_PX))


def _path_scene(family: str, rng: np.random.Generator) -> tuple[Any, str, Any, int]:
    """The random fruit of an arc or row case, its view description, its camera path and its number of views."""
    n = int(rng.integers(5, 9))
    n_fruit = int(rng.integers(6, 9))
    if family == "arc":
        scene = random_scene(n_fruit, rng)
        span_deg = float(rng.uniform(50.0, 70.0))
        target = scene_target(scene)

        def path(at: NDArray[np.float64]) -> NDArray[np.float64]:
            return arc_poses(target, n, span=math.radians(span_deg), at=at)

        return scene, f"arc:{n}:{span_deg:.0f}", path, n
    scene = random_scene(n_fruit, rng, half_extent=ROW_FRUIT_HALF_EXTENT)
    length = float(rng.uniform(0.3, 0.4))
    target = scene_target(scene)

    def row(at: NDArray[np.float64]) -> NDArray[np.float64]:
        return row_poses(n, target, length=length, distance=ROW_DISTANCE_M, at=at)

    return scene, f"row:{n}:{length:.2f}", row, n
