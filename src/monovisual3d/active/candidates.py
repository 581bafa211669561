"""Candidate camera poses for the next-best-view planner: from a file or generated on a spherical cap.

A candidate is a ``T_base_optical`` (4, 4). Generated candidates (:func:`cap_poses`)
look at a target point from a spherical cap around it: the cap's axis points from
the target towards ``axis`` (by default the base origin, where the arm stands),
azimuth is measured about base +z from that axis, elevation from the horizontal plane.
An arm-reach sphere (radius ``reach`` around ``base_centre``) removes the poses the arm
cannot reach.

The CLI spec is ``cap:N[:distance=LO..HI][:azimuth=LO..HI][:elevation=LO..HI][:reach=R]``
(metres and degrees), e.g. ``cap:60:distance=0.4..0.6:azimuth=-60..60:reach=0.95``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import is_int, is_real
from ..errors import InputError
from ..frames import (
    ROTATION_TOL,
    T_base_optical_from_T_base_cameralink,
    check_transform,
    look_at,
    position_quaternion_from_transform,
)
from ..limits import MAX_CANDIDATES

#: Digits of the N in ``cap:N`` read as a number (longer is over the limit, not parsed).
_MAX_DIGITS = 12

#: Golden ratio conjugates of the 3-D R-sequence (a low-discrepancy sequence: deterministic, evenly spread).
_PHI3 = 1.2207440846057596  # root of x^4 = x + 1
_R3 = (1 / _PHI3, 1 / _PHI3**2, 1 / _PHI3**3)


@dataclass(frozen=True)
class CapSpec:
    """A spherical cap of camera positions that look at a target.

    Attributes
    ----------
    n : int, poses generated before the reach filter
    distance_m : (lo, hi), metres, camera-to-target distance
    azimuth_deg : (lo, hi), degrees about base +z, 0 = on the axis from the target towards ``axis``
    elevation_deg : (lo, hi), degrees above the horizontal plane through the target
    reach_m : float, radius of the arm-reach sphere around ``base_centre`` (inf: no filter)
    """

    n: int = 60
    distance_m: tuple[float, float] = (0.4, 0.6)
    azimuth_deg: tuple[float, float] = (-60.0, 60.0)
    elevation_deg: tuple[float, float] = (-35.0, 45.0)
    reach_m: float = math.inf

    def __post_init__(self) -> None:
        if not is_int(self.n) or self.n < 1:
            raise InputError(f"cap: N: got {self.n!r}, expected a positive integer")
        if self.n > MAX_CANDIDATES:
            raise InputError(f"cap: N: got {self.n}, more than the {MAX_CANDIDATES} candidates accepted")
        _check_range(self.distance_m, "distance", 0.0, math.inf, "metres", open_low=True)
        _check_range(self.azimuth_deg, "azimuth", -180.0, 180.0, "degrees")
        _check_range(self.elevation_deg, "elevation", -90.0, 90.0, "degrees")
        if not (is_real(self.reach_m) and self.reach_m > 0 and not math.isnan(self.reach_m)):
            raise InputError(f"cap: reach: got {self.reach_m!r}, expected a positive number of metres")

    @classmethod
    def parse(cls, spec: str) -> CapSpec:
        """Parse ``cap:N[:distance=LO..HI][:azimuth=LO..HI][:elevation=LO..HI][:reach=R]``.

        Examples
        --------
        >>> CapSpec.parse("cap:10:azimuth=-30..30").azimuth_deg
        (-30.0, 30.0)
        """
        head, _, rest = spec.strip().partition(":")
        if head != "cap" or not rest:
            raise InputError(
                f"--candidates: got {spec!r}, expected cap:N[:distance=LO..HI][:azimuth=LO..HI][:elevation=LO..HI][:reach=R]"
            )
        parts = rest.split(":")
        if parts[0].strip().isdigit() and (len(parts[0].strip()) > _MAX_DIGITS or int(parts[0]) > MAX_CANDIDATES):
            raise InputError(f"--candidates: got {spec!r}, more than the {MAX_CANDIDATES} candidates accepted (cap:N)")
        try:
            n = int(parts[0])
        except ValueError:
            raise InputError(f"--candidates: got {spec!r}, expected cap:N with N an integer") from None
        kwargs: dict[str, Any] = {"n": n}
        names = {"distance": "distance_m", "azimuth": "azimuth_deg", "elevation": "elevation_deg"}
        for part in parts[1:]:
            key, eq, value = part.partition("=")
            if not eq:
                raise InputError(f"--candidates: {part!r} in {spec!r}: expected KEY=VALUE")
            if key in names:
                lo, sep, hi = value.partition("..")
                try:
                    kwargs[names[key]] = (float(lo), float(hi)) if sep else (float(value), float(value))
                except ValueError:
                    raise InputError(f"--candidates: {key}: got {value!r}, expected LO..HI (two numbers)") from None
            elif key == "reach":
                try:
                    kwargs["reach_m"] = float(value)
                except ValueError:
                    raise InputError(f"--candidates: reach: got {value!r}, expected metres") from None
            else:
                raise InputError(f"--candidates: unknown key {key!r} in {spec!r}, expected distance, azimuth, elevation or reach")
        return cls(**kwargs)


def cap_poses(
    spec: CapSpec,
    target: ArrayLike,
    *,
    axis: ArrayLike | None = None,
    base_centre: ArrayLike = (0.0, 0.0, 0.0),
) -> NDArray[np.float64]:
    """Poses on a spherical cap, looking at ``target``; those outside the reach sphere are removed.

    Parameters
    ----------
    spec : CapSpec
    target : array_like, shape (3,), metres, base frame
    axis : array_like, shape (3,), base frame, a point the cap faces (default ``base_centre``); only its
        horizontal direction from ``target`` is used
    base_centre : array_like, shape (3,), metres, centre of the reach sphere

    Returns
    -------
    T_base_optical : ndarray, shape (K, 4, 4), K <= spec.n, in generation order (deterministic)

    Examples
    --------
    >>> cap_poses(CapSpec(n=8), [0.6, 0.0, 0.45]).shape
    (8, 4, 4)
    """
    t = np.asarray(target, dtype=float)
    b = np.asarray(base_centre, dtype=float)
    a = np.asarray(axis if axis is not None else b, dtype=float) - t
    a[2] = 0.0
    if np.linalg.norm(a) < 1e-9:
        a = np.array([-1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    k = np.arange(spec.n) + 0.5
    u = (k * _R3[0]) % 1.0
    v = (k * _R3[1]) % 1.0
    w = (k * _R3[2]) % 1.0
    az = np.radians(spec.azimuth_deg[0] + u * (spec.azimuth_deg[1] - spec.azimuth_deg[0]))
    s_lo, s_hi = np.sin(np.radians(spec.elevation_deg))
    el = np.arcsin(s_lo + v * (s_hi - s_lo))  # equal area in elevation
    d = spec.distance_m[0] + w * (spec.distance_m[1] - spec.distance_m[0])
    side = np.cross([0.0, 0.0, 1.0], a)
    horiz = np.cos(az)[:, None] * a + np.sin(az)[:, None] * side
    direction = np.cos(el)[:, None] * horiz + np.sin(el)[:, None] * np.array([0.0, 0.0, 1.0])
    positions = t + d[:, None] * direction
    keep = np.linalg.norm(positions - b, axis=1) <= spec.reach_m
    if not keep.any():
        raise InputError(
            f"cap: all {spec.n} poses are outside the reach sphere ({spec.reach_m} m); increase reach or move the cap"
        )
    return np.stack([look_at(p, t) for p in positions[keep]])


def load_candidates(path: str | Path, pose_frame: str = "optical") -> NDArray[np.float64]:
    """Candidate poses from ``{"poses": [{"position": [...], "quaternion_xyzw": [...]}, ...]}`` (JSON/YAML).

    Items may also be ``{"matrix": 4x4}``. A ``"pose_frame"`` key in the file overrides ``pose_frame``
    (``optical`` or ``camera_link``, as in a session).

    Returns
    -------
    T_base_optical : ndarray, shape (N, 4, 4)
    """
    from .._structured import read_structured_file
    from ..session.load import pose_from_dict

    data = read_structured_file(path)
    if isinstance(data, dict):
        pose_frame = data.get("pose_frame", pose_frame)
        if "poses" not in data:
            raise InputError(f"{path}: poses: missing field, expected a list of {{position, quaternion_xyzw}}")
        data = data["poses"]
    if pose_frame not in ("optical", "camera_link"):
        raise InputError(f"{path}: pose_frame: got {pose_frame!r}, expected optical or camera_link")
    if not isinstance(data, list):
        raise InputError(f"{path}: poses: expected a list of {{position, quaternion_xyzw}}")
    if not data:
        raise InputError(f"{path}: poses: empty list, expected at least one candidate pose")
    if len(data) > MAX_CANDIDATES:
        raise InputError(f"{path}: poses: {len(data)} candidate poses, more than the {MAX_CANDIDATES} accepted")
    out = []
    for i, item in enumerate(data):
        try:
            T = pose_from_dict(item, f"poses[{i}]")
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
        out.append(T_base_optical_from_T_base_cameralink(T) if pose_frame == "camera_link" else T)
    return np.stack(out)


def check_candidates(candidates: ArrayLike) -> NDArray[np.float64]:
    """Validate candidate poses, shape (N, 4, 4) with N >= 1 (rigid transforms).

    Examples
    --------
    >>> check_candidates(np.eye(4)[None]).shape
    (1, 4, 4)
    """
    P = np.asarray(candidates, dtype=float)
    if P.ndim != 3 or P.shape[1:] != (4, 4):
        raise InputError(f"candidates: expected shape (N, 4, 4), got {P.shape}")
    if len(P) == 0:
        raise InputError("candidates: empty list, expected at least one candidate pose")
    if len(P) > MAX_CANDIDATES:
        raise InputError(f"candidates: {len(P)} candidate poses, more than the {MAX_CANDIDATES} accepted")
    with np.errstate(over="ignore", invalid="ignore"):
        R = P[:, :3, :3]
        err = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
        ok = (
            np.isfinite(P).all(axis=(1, 2))
            & (err <= ROTATION_TOL)
            & (np.linalg.det(R) > 0)
            & (np.abs(P[:, 3] - [0.0, 0.0, 0.0, 1.0]).max(axis=1) <= 1e-9)
        )
    for i in np.flatnonzero(~ok):  # the reference check names the problem
        check_transform(P[i], where=f"candidates[{i}]")
    return P


def pose_to_dict(T_base_optical: ArrayLike, pose_frame: str = "optical") -> dict[str, list[float]]:
    """``{"position", "quaternion_xyzw"}`` of a pose, in ``pose_frame`` (optical or camera_link)."""
    T = np.asarray(T_base_optical, dtype=float)
    if pose_frame == "camera_link":
        from ..frames import T_cameralink_optical

        T = T @ np.linalg.inv(T_cameralink_optical())
    p, q = position_quaternion_from_transform(T)
    return {"position": [float(x) for x in p], "quaternion_xyzw": [float(x) for x in q]}


def _check_range(r: Any, name: str, lo: float, hi: float, unit: str, open_low: bool = False) -> None:
    try:
        a, b = (float(x) for x in r)
    except (TypeError, ValueError):
        raise InputError(f"cap: {name}: got {r!r}, expected LO..HI {unit}") from None
    low_ok = a > lo if open_low else a >= lo
    if not (math.isfinite(a) and math.isfinite(b) and low_ok and b <= hi and a <= b):
        bound = f"({lo:g}, {hi:g}]" if open_low else f"[{lo:g}, {hi:g}]"
        raise InputError(f"cap: {name}: got {a:g}..{b:g}, expected LO <= HI within {bound} {unit}")
