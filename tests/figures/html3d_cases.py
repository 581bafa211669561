"""Scenes shared by the 3D view's tests (and the rerun recording's): two spheres seen from three views."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from monovisual3d import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.sphere import sphere_bbox

CAM = Camera.from_hfov(640, 480, 69.0)
CENTRES = np.array([[0.6, 0.03, 0.45], [0.62, -0.05, 0.40]])
RADII = np.array([0.03, 0.025])


def two_fruit_session() -> dict[str, Any]:
    """Three views of two spheres (exact boxes), with a workspace."""
    target = CENTRES.mean(axis=0)
    views = []
    for d in ([-1.0, 0.0, 0.0], [-0.5, 0.85, 0.0], [-0.5, -0.45, 0.75]):
        d = np.array(d) / np.linalg.norm(d)
        T = look_at(target + 0.45 * d, target)
        dets = [{"bbox_xyxy": sphere_bbox(CAM, T, c, r).tolist(), "score": 0.9} for c, r in zip(CENTRES, RADII)]
        views.append({"pose": {"matrix": T.tolist()}, "detections": dets})
    return {
        "camera": {"width": 640, "height": 480, "hfov_deg": 69.0},
        "views": views,
        "workspace": {"min": [0.4, -0.2, 0.2], "max": [0.8, 0.2, 0.7]},
    }


def result_dict() -> dict[str, Any]:
    q = Rotation.from_euler("z", 30, degrees=True).as_quat().tolist()
    return {
        "method": "bayes",
        "objects": [
            {
                "position": (CENTRES[0] + [0.004, 0, 0]).tolist(),
                "score": 20.0,
                "radius": 0.031,
                "covariance": np.diag([4e-6, 1e-6, 1e-6]).tolist(),
            },
            {
                "position": (CENTRES[1] - [0, 0.003, 0]).tolist(),
                "score": 10.0,
                "semi_axes": [0.03, 0.02, 0.02],
                "quaternion_xyzw": q,
            },
            {"position": [0.7, 0.1, 0.6], "score": 2.0},  # no size: a marker; no truth to match
        ],
    }


def truth_dict() -> dict[str, Any]:
    return {"objects": [{"position": c.tolist(), "radius": float(r)} for c, r in zip(CENTRES, RADII)]}


def by_kind(fig: Any, kind: str) -> list[Any]:
    return [t for t in fig.data if t.meta["kind"] == kind]
