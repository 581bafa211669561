"""``plan_session``: the library call behind ``next-view``; its errors name its parameters."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from monovisual3d.active.api import parse_point, plan_session
from monovisual3d.errors import InputError
from monovisual3d.sim import paper_scene
from monovisual3d.sim.simulate import simulate


@pytest.fixture(scope="module")
def session_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    session, _ = simulate(paper_scene(), rng=0)
    path = tmp_path_factory.mktemp("s") / "session.json"
    session.to_json(path)
    return path


@pytest.fixture(scope="module")
def empty_path(session_path: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    raw = json.loads(session_path.read_text())
    path = tmp_path_factory.mktemp("e") / "empty.json"
    path.write_text(json.dumps({**raw, "views": []}))
    return path


def test_plan_session_returns_the_plan_with_the_cap_candidates(session_path: Path) -> None:
    out = plan_session(session_path, "cap:12", count=2)
    assert out["views"] == 3 and out["n_objects"] == 6
    assert len(out["candidates"]) == 12
    assert len(out["indices"]) == 2 and out["index"] == out["indices"][0]
    assert sorted(r["index"] for r in out["ranking"]) == list(range(12))


def test_plan_session_on_an_empty_session_with_a_target(empty_path: Path) -> None:
    out = plan_session(empty_path, "cap:6", target=(0.6, 0.0, 0.45))
    assert out["views"] == 0 and out["n_objects"] == 0
    centre = np.mean([c["position"] for c in out["candidates"]], axis=0)
    assert np.linalg.norm(centre - [0.6, 0.0, 0.45]) < 0.6


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"count": 0}, r"^count: got 0, expected a positive integer"),
        ({"count": 6}, r"^count: got 6, expected at most 5"),
        ({"reach_m": -1.0}, r"^reach_m: got -1.0, expected a positive number"),
        ({"base": "1,2"}, r"^base: got '1,2', expected X,Y,Z in metres"),
        ({"base": (0.0, float("nan"), 0.0)}, r"^base: got .*expected X,Y,Z"),
        ({"target": "x"}, r"^target: got 'x', expected X,Y,Z in metres"),
    ],
)
def test_plan_session_errors_name_the_parameter(session_path: Path, kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        plan_session(session_path, "cap:5", **kwargs)


def test_plan_session_needs_a_target_without_views_or_workspace(empty_path: Path) -> None:
    with pytest.raises(InputError, match=r"no views and no workspace; give target X,Y,Z"):
        plan_session(empty_path, "cap:5")


def test_parse_point_accepts_text_and_numbers() -> None:
    assert parse_point("1,2.5,-3", "p") == (1.0, 2.5, -3.0)
    assert parse_point([1, 2, 3], "p") == (1.0, 2.0, 3.0)
    with pytest.raises(InputError, match=r"^p: got None"):
        parse_point(None, "p")  # type: ignore[arg-type]


def test_tool_goal_poses_in_a_camera_link_session(session_path: Path, tmp_path: Path) -> None:
    """The hand-eye transform is the camera in the tool frame in the session's convention (here camera_link)."""
    from numpy.testing import assert_allclose

    from monovisual3d.frames import T_cameralink_optical, invert_transform, look_at, transform_from_position_quaternion
    from monovisual3d.session.load import load_session

    session = load_session(session_path)
    data = json.loads(session_path.read_text())
    data["pose_frame"] = "camera_link"
    for view, v in zip(data["views"], session.views, strict=True):
        view["pose"] = {"matrix": (v.T_base_optical @ invert_transform(T_cameralink_optical())).tolist()}
    path = tmp_path / "camera_link.json"
    path.write_text(json.dumps(data))
    T_tool_cameralink = look_at([0.05, 0.0, 0.1], [1.0, 0.2, 0.3])
    out = plan_session(path, "cap:10", tool_frame="tool0", T_tool_camera=T_tool_cameralink)
    assert out["pose_frame"] == "camera_link" and out["tool_frame"] == "tool0"
    tool, camera = out["pose"], out["camera_pose"]
    T_base_tool = transform_from_position_quaternion(tool["position"], tool["quaternion_xyzw"])
    T_base_cameralink = transform_from_position_quaternion(camera["position"], camera["quaternion_xyzw"])
    assert_allclose(T_base_tool @ T_tool_cameralink, T_base_cameralink, atol=1e-12)
    assert camera == out["candidates"][out["index"]]


def test_tool_frame_needs_the_hand_eye(session_path: Path) -> None:
    with pytest.raises(InputError, match=r"^tool_frame: give the tool frame's name together with the hand-eye"):
        plan_session(session_path, "cap:5", tool_frame="tool0")
    with pytest.raises(InputError, match=r"T_tool_camera"):
        plan_session(session_path, "cap:5", tool_frame="tool0", T_tool_camera=np.ones((4, 4)))
