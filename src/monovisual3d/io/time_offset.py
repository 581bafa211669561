"""The time offset between a pose stream and the images, estimated from the boxes (``import --time-offset auto``).

A pose stream whose clock runs ``d`` seconds ahead of the images' (a late TF, a camera driver's latency left
uncorrected) gives each image the pose the camera had ``d`` later. Looked up at the image stamps minus the right
``d``, the poses make every fruit's viewing rays meet; at a wrong ``d`` each view is moved along the camera's path
and the rays of one fruit miss each other. :func:`ray_misfit` scores that without any method (and so without an
association): for each box, the distance of its centre's viewing ray to the nearest ray of a box in every other
view, capped at :data:`RAY_CAP_M` (a fruit that view does not see, a false box); :func:`estimate_time_offset`
searches ``d`` over :data:`SEARCH_FRAMES` frames either side of zero and refines the minimum with a parabola.

What it cannot see: where the camera moves at constant velocity along one path (an arc about one axis at constant
speed, a straight row), moving every view along the path by the same time is one rigid motion of all the cameras;
the rays meet as well at any offset and the scene only moves with them. The misfit then stays flat (within
:data:`FLAT_SHARE` of its value over a frame either side): the offset is reported as not determined and not
applied. It is observable where the speed or the direction of motion changes between views.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from ..errors import InputError
from .detections import ImageDetections
from .poses import PoseTrajectory, interpolate_poses

#: A box's ray further than this from every ray of another view counts as this far (metres): a fruit that view does
#: not see or a false box must not drive the offset.
RAY_CAP_M = 0.03
#: The offsets searched: this many frames either side of zero, at this many steps per frame.
SEARCH_FRAMES, STEPS_PER_FRAME = 2.0, 8
#: Misfit that changes by less than this share of its lowest value over a frame either side of the minimum is
#: flat: the offset is not determined by the views (why: docs/decisions/bayes-corrections.md#time-offsets-on-a-path-of-constant-speed).
FLAT_SHARE = 0.05
#: Largest time between an image's shifted stamp and the stream samples used for it, seconds.
SEARCH_MAX_GAP_S = 1.0


@dataclass(frozen=True)
class TimeOffset:
    """What :func:`estimate_time_offset` returns.

    Attributes
    ----------
    offset_s : float, seconds: how far the pose stream runs ahead of the images (0 where not determined)
    determined : bool, whether the views tell it (False: the misfit is flat, see the module docstring)
    frame_s : float, seconds, the median time between images
    searched_s : ndarray, shape (K,), the offsets tried
    misfit : ndarray, shape (K,), :func:`ray_misfit` at each
    note : str, one line for the import summary
    """

    offset_s: float
    determined: bool
    frame_s: float
    searched_s: NDArray[np.float64]
    misfit: NDArray[np.float64]
    note: str


def _rays(camera: Camera, frames: Sequence[ImageDetections]) -> list[NDArray[np.float64]]:
    """Each image's boxes as unit rays in its optical frame, shape (B_i, 3): per image axis the bisector of the angles
    of the box's two edges (a sphere's centre lies exactly on it; the box's centre does not, off the image centre)."""
    out = []
    for f in frames:
        if not f.detections:
            out.append(np.zeros((0, 3)))
            continue
        boxes = np.array([d.bbox_xyxy for d in f.detections], dtype=float)
        corners = camera.normalised_from_pixels(np.concatenate([boxes[:, :2], boxes[:, 2:]]))
        if camera.distortion_model != "none":
            corners = camera.undistort(corners)
        lo, hi = corners[: len(boxes)], corners[len(boxes) :]
        xy = np.tan(0.5 * (np.arctan(lo) + np.arctan(hi)))
        r = np.column_stack([xy, np.ones(len(xy))])
        out.append(r / np.linalg.norm(r, axis=1, keepdims=True))
    return out


def ray_misfit(T_base_optical: NDArray[np.float64], rays_optical: Sequence[NDArray[np.float64]]) -> float:
    """Sum over the boxes of every view of the squared distance (m^2) of its ray to the nearest ray of each other view,
    each capped at :data:`RAY_CAP_M`.

    Parameters
    ----------
    T_base_optical : ndarray, shape (V, 4, 4), the views' poses
    rays_optical : list of ndarray, shape (B_v, 3), unit rays of the box centres, optical frame
    """
    origins = T_base_optical[:, :3, 3]
    dirs = [r @ T[:3, :3].T for T, r in zip(T_base_optical, rays_optical)]
    total = 0.0
    for i in range(len(dirs)):
        for j in range(len(dirs)):
            if i == j or not len(dirs[i]) or not len(dirs[j]):
                continue
            n = np.cross(dirs[i][:, None, :], dirs[j][None, :, :])  # (Bi, Bj, 3)
            norm = np.linalg.norm(n, axis=-1)
            w = origins[j] - origins[i]
            with np.errstate(invalid="ignore", divide="ignore"):
                d = np.abs(n @ w) / norm
            d = np.where(norm > 1e-9, d, RAY_CAP_M)
            total += float(np.sum(np.minimum(d.min(axis=1), RAY_CAP_M) ** 2))
    return total


def estimate_time_offset(
    camera: Camera,
    poses: PoseTrajectory,
    frames: Sequence[ImageDetections],
    to_optical: Callable[[NDArray[np.float64]], NDArray[np.float64]] = lambda T: T,
) -> TimeOffset:
    """How far the pose stream ``poses`` runs ahead of the images ``frames`` (see the module docstring).

    Parameters
    ----------
    camera : Camera
    poses : PoseTrajectory with stamps, the stream
    frames : list of ImageDetections with stamps, the images' boxes
    to_optical : the stream's poses (N, 4, 4) -> ``T_base_optical`` (N, 4, 4) (a hand-eye calibration, camera_link)

    Returns
    -------
    TimeOffset
    """
    if poses.stamps is None or any(f.stamp is None for f in frames):
        raise InputError("--time-offset auto (time_offset='auto'): needs time stamps on the poses and on every image")
    frames = sorted(frames, key=lambda f: float(f.stamp))  # type: ignore[arg-type]
    stamps = np.array([float(f.stamp) for f in frames])  # type: ignore[arg-type]
    if len(stamps) < 3:
        raise InputError(f"--time-offset auto (time_offset='auto'): {len(stamps)} images, at least 3 are needed")
    frame_s = float(np.median(np.diff(stamps)))
    rays = _rays(camera, frames)
    step = frame_s / STEPS_PER_FRAME
    k = int(round(SEARCH_FRAMES * STEPS_PER_FRAME))
    searched = step * np.arange(-k, k + 1)
    misfit = np.full(len(searched), np.nan)
    for n, d in enumerate(searched):
        if stamps[0] - d < poses.stamps[0] or stamps[-1] - d > poses.stamps[-1]:
            continue  # the stream must hold every image's pose on both sides (a clamped pose is no motion)
        T, ok, _ = interpolate_poses(poses.stamps, poses.T_base_frame, stamps - d, SEARCH_MAX_GAP_S)
        if np.all(ok):
            misfit[n] = ray_misfit(to_optical(T), rays)
    return _minimum(searched, misfit, frame_s)


def _minimum(searched: NDArray[np.float64], misfit: NDArray[np.float64], frame_s: float) -> TimeOffset:
    """The offset of least misfit (refined by a parabola), or not determined where the misfit is flat or least at the
    end of the offsets searched."""
    step = float(searched[1] - searched[0])
    if not np.any(np.isfinite(misfit)):
        raise InputError("--time-offset auto (time_offset='auto'): the pose stream does not cover the images")
    best = int(np.nanargmin(misfit))
    lo = misfit[np.isfinite(misfit)].min()
    near = misfit[max(0, best - STEPS_PER_FRAME) : best + STEPS_PER_FRAME + 1]
    near = near[np.isfinite(near)]
    flat = float(near.max() - lo) <= FLAT_SHARE * max(lo, 1e-12)
    finite = np.flatnonzero(np.isfinite(misfit))
    edge = best in (finite[0], finite[-1])
    if flat or edge:
        why = (
            "it lies beyond the offsets searched"
            if edge and not flat
            else (
                "the camera moved at constant velocity along one path, where moving every view along it is one rigid "
                "motion of the cameras"
            )
        )
        note = f"time offset: not determined by these views ({why}); poses looked up at the image stamps as given"
        return TimeOffset(0.0, False, frame_s, searched, misfit, note)
    offset = float(searched[best])
    if 0 < best < len(searched) - 1 and np.all(np.isfinite(misfit[best - 1 : best + 2])):
        a, b, c = misfit[best - 1 : best + 2]
        curv = a - 2 * b + c
        if curv > 0:
            offset += step * 0.5 * (a - c) / curv
    note = (
        f"time offset: the pose stream runs {offset:+.4f} s ({offset / frame_s:+.2f} frames) ahead of the images, "
        "estimated from the boxes' rays; poses looked up at the image stamps minus it"
    )
    return TimeOffset(offset, True, frame_s, searched, misfit, note)


def shifted(poses: PoseTrajectory, offset_s: float) -> PoseTrajectory:
    """The stream with its stamps moved ``+offset_s`` (a lookup at an image stamp ``t`` then gives the sample stamped
    ``t - offset_s``: the pose of a stream running ``offset_s`` ahead, undone)."""
    if poses.stamps is None:
        raise InputError("--time-offset (time_offset): the poses have no time stamps")
    if not math.isfinite(offset_s):
        raise InputError(f"--time-offset (time_offset): got {offset_s!r}, expected seconds or 'auto'")
    return PoseTrajectory(poses.T_base_frame, poses.stamps + offset_s, poses.images, poses.source)
