"""Warnings about view geometry that cannot triangulate depth: one view, one pose, or too small a baseline.

The session loader (:mod:`monovisual3d.session.load`) calls :func:`geometry_warnings` on every session it
loads; the CLI also calls it with ``single_view=True`` before a method runs. Numpy only, on the session's
poses: part of the core, so that the loader needs nothing above it.
"""

from __future__ import annotations

import numpy as np

from .model import Session

#: Views whose camera positions span less than this angle, seen from the scene, cannot triangulate depth well.
MIN_BASELINE_DEG = 3.0
#: Views closer than this (metres) and turned less than :data:`SAME_POSE_DEG` count as the same pose: a
#: millimetre and a tenth of a degree are below what arm kinematics repeat.
SAME_POSE_M = 1e-3
SAME_POSE_DEG = 0.1
#: Above this condition number the optical axes are taken as parallel (no point closest to all of them).
PARALLEL_AXES_CONDITION = 1e6
#: With parallel optical axes the scene point is taken this far in front of the cameras, metres.
PARALLEL_AXES_DEPTH_M = 1.0
#: A camera closer than this to the scene point (metres, rounding level) gives no direction to measure angles from.
AT_SCENE_POINT_M = 1e-9


def geometry_warnings(session: Session, *, single_view: bool = False) -> list[str]:
    """Warnings about view geometry that cannot triangulate depth (empty when the views are well spread).

    Parameters
    ----------
    session : Session
    single_view : bool
        Also warn when the session has a single view (a method asked to localise from one view).

    Returns
    -------
    list of str, one-line messages naming the field (``views``)

    Notes
    -----
    The scene point is the workspace centre when there is a workspace, else the
    point closest to all optical axes (1 m in front of the cameras when the axes
    are parallel). The baseline is the largest angle between two camera
    positions seen from that point.
    """
    views = session.views
    n = len(views)
    if n == 1:
        return ["views: a single view; depth comes from the box size alone, give views from several poses"] if single_view else []
    T = np.stack([v.T_base_optical for v in views])
    P, Z = T[:, :3, 3], T[:, :3, 2]
    R0 = T[0, :3, :3]
    cos_rot = np.clip((np.einsum("nij,ij->n", T[:, :3, :3], R0) - 1) / 2, -1.0, 1.0)
    if np.all(np.linalg.norm(P - P[0], axis=1) < SAME_POSE_M) and np.all(np.degrees(np.arccos(cos_rot)) < SAME_POSE_DEG):
        return [f"views: all {n} views have the same pose; depth cannot be triangulated from one viewpoint"]
    if session.workspace is not None:
        target = 0.5 * (session.workspace.min + session.workspace.max)
    else:
        A = n * np.eye(3) - Z.T @ Z
        b = (P - Z * np.sum(Z * P, axis=1, keepdims=True)).sum(0)
        target = P.mean(0) + PARALLEL_AXES_DEPTH_M * Z.mean(0)
        if np.linalg.cond(A) < PARALLEL_AXES_CONDITION:
            candidate = np.linalg.solve(A, b)
            if np.all(np.sum((candidate - P) * Z, axis=1) > 0):
                target = candidate
    d = P - target
    norm = np.linalg.norm(d, axis=1)
    if np.any(norm < AT_SCENE_POINT_M):  # a camera at the scene point: no angle to measure
        return []
    u = d / norm[:, None]
    far = int(np.argmin(u @ u[0]))  # two passes of farthest direction: the largest pairwise angle, to a factor < 2
    span = float(np.degrees(np.arccos(np.clip(np.min(u @ u[far]), -1.0, 1.0))))
    if span < MIN_BASELINE_DEG:
        where = ", ".join(f"{x:.3g}" for x in target)
        return [
            f"views: the camera positions span {span:.2g} degrees seen from the scene (near [{where}] m), under "
            f"{MIN_BASELINE_DEG:g}; depth is poorly determined, move the camera farther between views"
        ]
    return []
