"""Warnings about view geometry (:mod:`monovisual3d.session.baseline`): one view, one pose, too small a baseline."""

from __future__ import annotations

import numpy as np

from monovisual3d.camera import Camera
from monovisual3d.frames import look_at
from monovisual3d.session import Session, View, Workspace
from monovisual3d.session.baseline import MIN_BASELINE_DEG, geometry_warnings

CAMERA = Camera(width=640, height=480, fx=500.0, fy=500.0, cx=320.0, cy=240.0)
TARGET = np.array([0.0, 0.0, 1.0])


def _session(positions: list[list[float]], workspace: Workspace | None = None) -> Session:
    views = tuple(View(T_base_optical=look_at(np.array(p, dtype=float), TARGET)) for p in positions)
    return Session(camera=CAMERA, views=views, workspace=workspace)


def test_a_single_view_warns_only_when_asked() -> None:
    one = _session([[0.0, 0.0, 0.0]])
    assert geometry_warnings(one) == []
    assert "a single view" in geometry_warnings(one, single_view=True)[0]


def test_views_from_one_pose_cannot_triangulate() -> None:
    messages = geometry_warnings(_session([[0.0, 0.0, 0.0]] * 3))
    assert messages == ["views: all 3 views have the same pose; depth cannot be triangulated from one viewpoint"]


def test_the_baseline_is_the_angle_seen_from_the_scene() -> None:
    # 1 cm apart at 1 m: about 0.6 degrees, under the threshold; 30 cm apart: about 17 degrees
    narrow = geometry_warnings(_session([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]]))
    assert len(narrow) == 1 and f"under {MIN_BASELINE_DEG:g}" in narrow[0]
    assert geometry_warnings(_session([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0]])) == []


def test_the_workspace_centre_is_the_scene_point() -> None:
    near = Workspace(min=np.array([-0.01, -0.01, 0.04]), max=np.array([0.01, 0.01, 0.06]))  # 5 cm in front
    positions = [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]]
    assert geometry_warnings(_session(positions)) != []  # seen from 1 m: too narrow
    assert geometry_warnings(_session(positions, near)) == []  # seen from 5 cm: about 11 degrees
