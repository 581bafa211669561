"""Shared fixtures of the core tests: cameras, synthetic sphere sessions, session dicts."""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from monovisual3d import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.sphere import sphere_bbox

#: Camera of the paper's testbed (OAK-1 like): 640x480, HFOV 69 degrees.
HFOV_DEG = 69.0


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240611)


@pytest.fixture
def camera() -> Camera:
    return Camera.from_hfov(640, 480, HFOV_DEG)


def spread_poses(centre: np.ndarray, distance: float = 0.45) -> list[np.ndarray]:
    """``T_base_optical`` of three cameras looking at ``centre`` from well-spread directions.

    One view from -x (straight ahead of the robot), one from the left and one
    from above-right: about 60-75 degrees between any two optical axes.
    """
    directions = [np.array([-1.0, 0.0, 0.0]), np.array([-0.5, 0.85, 0.0]), np.array([-0.5, -0.45, 0.75])]
    poses = []
    for d in directions:
        d = d / np.linalg.norm(d)
        poses.append(look_at(centre + distance * d, centre))
    return poses


#: Nominal sphere centre (metres, base frame): 0.6 m in front of the robot, like the shipped example.
NOMINAL_CENTRE = np.array([0.6, 0.0, 0.45])


def sphere_session_dict(
    camera: Camera, centre: np.ndarray, radius: float, poses: list[np.ndarray], workspace_half: float | None = 0.1
) -> dict[str, Any]:
    """A session dict of one sphere seen from ``poses`` (exact silhouette boxes).

    The workspace, when given, is a cube of half side ``workspace_half`` around
    :data:`NOMINAL_CENTRE`, so a jittered ``centre`` falls anywhere within a cell.
    """
    views = []
    for T in poses:
        box = sphere_bbox(camera, T, centre, radius)
        assert np.all(np.isfinite(box)), "test setup: sphere must be visible in every view"
        views.append({"pose": {"matrix": T.tolist()}, "detections": [{"bbox_xyxy": box.tolist(), "score": 0.9}]})
    data: dict[str, Any] = {"camera": camera.to_dict(), "views": views}
    if workspace_half is not None:
        data["workspace"] = {"min": (NOMINAL_CENTRE - workspace_half).tolist(), "max": (NOMINAL_CENTRE + workspace_half).tolist()}
    return data


@pytest.fixture
def sphere_scene(camera: Camera, rng: np.random.Generator) -> Callable[..., tuple[dict[str, Any], np.ndarray, float]]:
    """Factory: ``(session_dict, centre_base, radius)`` of a 30 mm sphere near (0.6, 0, 0.45) m."""

    def make(workspace_half: float | None = 0.1) -> tuple[dict[str, Any], np.ndarray, float]:
        centre = NOMINAL_CENTRE + rng.uniform(-0.01, 0.01, 3)  # anywhere within a cell of the grid
        radius = 0.03
        return sphere_session_dict(camera, centre, radius, spread_poses(centre), workspace_half), centre, radius

    return make


#: A minimal valid session: one view looking along base +x with one box in the middle.
VALID_SESSION: dict[str, Any] = {
    "camera": {"width": 640, "height": 480, "fx": 462.4, "fy": 462.4, "cx": 320.0, "cy": 240.0},
    "views": [
        {
            "pose": {"position": [0.0, 0.0, 0.0], "quaternion_xyzw": [0.0, 0.0, 0.0, 1.0]},
            "detections": [{"bbox_xyxy": [300.0, 220.0, 340.0, 260.0], "score": 0.9, "label": "tomato"}],
        }
    ],
}


@pytest.fixture
def valid_session() -> dict[str, Any]:
    """A fresh deep copy of :data:`VALID_SESSION` that a test may mutate."""
    return copy.deepcopy(VALID_SESSION)


@pytest.fixture(autouse=True)
def _no_hard_exit_in_process(monkeypatch: pytest.MonkeyPatch) -> None:
    """A command run in this process (``CliRunner``) with ``--time-limit`` starts the watchdog that ends a stuck
    command-line run with ``os._exit`` (:func:`monovisual3d.budget.time_limit`); here it would end pytest itself
    when a loaded machine keeps the command in compiled code past the grace period (an uncached numba compile in a
    clean clone). In-process, the soft limit (the ``TimeLimitExceeded`` the tests check) is all that may act;
    commands run as subprocesses keep the hard exit."""
    import monovisual3d.budget as budget

    monkeypatch.setattr(budget, "_hard_stop", lambda message: None)
