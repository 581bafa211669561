"""A camera moving along a path: when each view's image was taken, which pose the robot reports for it, the pose stream.

Views along an arc or a row (``--views arc:N[:SPAN_DEG]`` or ``row:N``; :func:`~.viewpoints.arc_poses`,
:func:`~.viewpoints.row_poses`) are the frames of one camera moving at constant speed, taken at ``frame_rate_hz``:
view ``k``'s image is stamped ``t_k = IMAGE_START_S + k / frame_rate_hz``. A pose stream that runs
``time_offset_s`` ahead of the images' clock (joint states or TF stamped late, a camera driver's latency left
uncorrected) reports for image ``k`` the pose the camera had at ``t_k + time_offset_s``: the path at the view
position ``k + time_offset_s * frame_rate_hz``. One frame late is ``time_offset_s = 1 / frame_rate_hz``: the pose
of the next view.

:func:`frame_times` also samples the path at :data:`POSE_RATE_HZ` with the same offset (the stream's sample
stamped ``s`` holds the path's pose at ``s + time_offset_s``), and :func:`write_import_files` writes it as the poses CSV
``monovisual3d import --poses`` reads (``stamp, x, y, z, qx, qy, qz, qw``, ``T_base_optical``) with the
detections as a CSV that carries the image stamps (``--detections``), so that ``import --match stamp`` rebuilds
the session from the stream: what an estimate of the time offset from the stream (``import --time-offset auto``)
starts from.
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import is_real
from ..errors import InputError
from ..frames import position_quaternion_from_transform
from ..limits import MAX_SIM_VIEWS

#: Stamp of the first image, seconds (any clock; not zero, as no real stamp is).
IMAGE_START_S = 100.0
#: Rate of the simulated pose stream, Hz (robot state publishers send 100-500 Hz).
POSE_RATE_HZ = 100.0
#: Default frame rate of the views along a path, Hz.
DEFAULT_FRAME_RATE_HZ = 5.0
#: Largest |time offset| simulated, in frames (the path is extrapolated that far beyond its ends).
MAX_OFFSET_FRAMES = 10.0
#: The pose stream starts this many frames before the first image and ends as many after the last (beyond the offset).
STREAM_MARGIN_FRAMES = 1.0

#: A camera path: continuous view positions (K,) -> ``T_base_optical`` (K, 4, 4) (``poses_by_name(spec, at=...)``).
CameraPath = Callable[[NDArray[np.float64]], NDArray[np.float64]]


@dataclass(frozen=True)
class FrameTimes:
    """Frames along a camera path: when each view's image was taken, the pose the robot reports for it, the pose stream.

    Attributes
    ----------
    stamps : ndarray, shape (N,), float64, seconds, the image time stamps
    T_base_optical_reported : ndarray, shape (N, 4, 4), the path's pose at ``stamps + time_offset_s`` (before the
        simulator's pose noise and hand-eye error)
    time_offset_s : float, seconds, how far ahead of the images' clock the pose stream runs
    frame_rate_hz : float, Hz, the rate the views were taken at
    stream_stamps : ndarray, shape (M,), seconds, strictly increasing, the pose stream's stamps (:data:`POSE_RATE_HZ`,
        covering the images with :data:`STREAM_MARGIN_FRAMES` frames to spare on both sides)
    stream_T_base_optical : ndarray, shape (M, 4, 4), the pose stream: the sample stamped ``s`` holds the path's pose
        at ``s + time_offset_s``
    """

    stamps: NDArray[np.float64]
    T_base_optical_reported: NDArray[np.float64]
    time_offset_s: float
    frame_rate_hz: float
    stream_stamps: NDArray[np.float64]
    stream_T_base_optical: NDArray[np.float64]

    def to_dict(self) -> dict[str, Any]:
        """The truth file's ``frames`` entry: offset, rate and image stamps."""
        return {
            "time_offset_s": self.time_offset_s,
            "frame_rate_hz": self.frame_rate_hz,
            "image_stamps": [float(s) for s in self.stamps],
        }


def check_timing(time_offset_s: float, frame_rate_hz: float) -> None:
    """Refuse a frame rate that is not positive, or a time offset beyond :data:`MAX_OFFSET_FRAMES` frames."""
    if not (is_real(frame_rate_hz) and np.isfinite(frame_rate_hz) and frame_rate_hz > 0):
        raise InputError(f"--frame-rate (frame_rate_hz): got {frame_rate_hz!r}, expected a positive number of frames per second")
    most = MAX_OFFSET_FRAMES / frame_rate_hz
    if not (is_real(time_offset_s) and np.isfinite(time_offset_s) and abs(time_offset_s) <= most):
        raise InputError(
            f"--time-offset (time_offset_s): got {time_offset_s!r}, expected seconds within +-{most:g} "
            f"({MAX_OFFSET_FRAMES:g} frames at {frame_rate_hz:g} Hz)"
        )


def frame_times(
    path: CameraPath, n_views: int, frame_rate_hz: float, time_offset_s: float = 0.0, *, pose_rate_hz: float = POSE_RATE_HZ
) -> FrameTimes:
    """The stamps of ``n_views`` frames along ``path``, and the poses a stream ``time_offset_s`` ahead reports.

    Parameters
    ----------
    path : callable, view positions (K,) -> ``T_base_optical`` (K, 4, 4); view ``k`` is at position ``k``
    n_views : int
    frame_rate_hz : float, Hz
    time_offset_s : float, seconds (positive: the reported poses are late, those of later frames)
    pose_rate_hz : float, Hz, the pose stream's rate

    Returns
    -------
    FrameTimes

    Examples
    --------
    >>> from monovisual3d.sim.viewpoints import arc_poses
    >>> ft = frame_times(lambda at: arc_poses(n=4, at=at), 4, 5.0, 0.2)
    >>> ft.stamps.round(6).tolist(), bool(np.allclose(ft.T_base_optical_reported[0], arc_poses(n=4)[1]))
    ([100.0, 100.2, 100.4, 100.6], True)
    >>> round(float(ft.stream_stamps[1] - ft.stream_stamps[0]), 6)
    0.01
    """
    if not (isinstance(n_views, int) and 1 <= n_views <= MAX_SIM_VIEWS):
        raise InputError(f"n_views: got {n_views!r}, expected 1..{MAX_SIM_VIEWS} views")
    check_timing(time_offset_s, frame_rate_hz)
    if not (is_real(pose_rate_hz) and np.isfinite(pose_rate_hz) and pose_rate_hz > 0):
        raise InputError(f"pose_rate_hz: got {pose_rate_hz!r}, expected a positive rate in Hz")
    k = np.arange(n_views, dtype=float)
    stamps = IMAGE_START_S + k / frame_rate_hz
    reported = np.asarray(path(k + time_offset_s * frame_rate_hz), dtype=float)
    margin = STREAM_MARGIN_FRAMES / frame_rate_hz
    first, last = stamps[0] - margin, stamps[-1] + margin
    stream_stamps = first + np.arange(int(np.ceil((last - first) * pose_rate_hz)) + 1) / pose_rate_hz
    stream = np.asarray(path((stream_stamps + time_offset_s - IMAGE_START_S) * frame_rate_hz), dtype=float)
    return FrameTimes(stamps, reported, float(time_offset_s), float(frame_rate_hz), stream_stamps, stream)


def write_import_files(
    directory: str | Path, session: Any, frames: FrameTimes, E_hand_eye: ArrayLike | None = None
) -> dict[str, Path]:
    """Write ``poses.csv`` (the pose stream) and ``detections.csv`` (the session's boxes with their image stamps).

    ``monovisual3d import --camera session.json --poses poses.csv --detections detections.csv --match stamp``
    rebuilds the session's views from them, each pose interpolated in the stream at its image's stamp. The
    stream is what the robot reports: the path's poses times ``E_hand_eye`` (the session's hand-eye error, where
    there is one); the per-view pose noise of the simulator is not in it.

    Parameters
    ----------
    directory : folder to write into (exists)
    session : Session whose views carry their image ``stamp``
    frames : FrameTimes, the pose stream
    E_hand_eye : array_like, shape (4, 4), optional

    Returns
    -------
    dict, ``{"poses": path, "detections": path}``
    """
    out = Path(directory)
    if any(v.stamp is None for v in session.views):
        raise InputError("session: every view needs its image stamp to write the detections CSV")
    T_stream = frames.stream_T_base_optical
    if E_hand_eye is not None:
        T_stream = T_stream @ np.asarray(E_hand_eye, dtype=float)
    paths = {"poses": out / "poses.csv", "detections": out / "detections.csv"}
    with paths["poses"].open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["stamp", "x", "y", "z", "qx", "qy", "qz", "qw"])
        for s, T in zip(frames.stream_stamps, T_stream):
            p, q = position_quaternion_from_transform(T)
            w.writerow([f"{s:.6f}", *(repr(float(v)) for v in p), *(repr(float(v)) for v in q)])
    with paths["detections"].open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["image", "stamp", "x1", "y1", "x2", "y2", "label"])
        for i, view in enumerate(session.views):
            name = view.image or f"view_{i:02d}.png"
            if not view.detections:
                w.writerow([name, f"{view.stamp:.6f}", "", "", "", "", ""])
            for d in view.detections:
                w.writerow([name, f"{view.stamp:.6f}", *(repr(float(v)) for v in d.bbox_xyxy), d.label or ""])
    return paths
