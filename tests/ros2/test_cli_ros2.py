"""``monovisual3d ros2 node`` and ``ros2 play``: bad input is one line naming the flag, before any DDS traffic."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")

from cli_checks import assert_one_line_error  # noqa: E402
from monovisual3d.cli import app  # noqa: E402
from monovisual3d.examples import example_session_path  # noqa: E402


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (["--tf-timeout", "-1"], ("--tf-timeout: got -1", "expected a number >= 0")),
        (["--detections", "yolo detections"], ("--detections: got 'yolo detections'", "expected a ROS 2 topic name")),
        (["--prefix", "/fruit/"], ("--prefix: got '/fruit/'",)),
        (["--pose-frame", "lens"], ("--pose-frame: got 'lens'", "optical", "camera_link")),
        (["--min-score", "2"], ("--min-score: got 2.0", "[0, 1]")),
        (["--accept", "nan"], ("--accept",)),
        (["--camera", "nowhere.yaml"], ("nowhere.yaml",)),
        (["--workspace", "1,2,3"], ("--workspace: got '1,2,3'",)),
    ],
    ids=["tf-timeout", "topic", "prefix", "pose-frame", "min-score", "method-option", "camera", "workspace"],
)
def test_node_refuses_bad_options(args: list[str], fragments: tuple[str, ...]) -> None:
    assert_one_line_error(CliRunner().invoke(app, ["ros2", "node", "--no-warmup", *args]), *fragments)


def test_node_refuses_a_bad_domain(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", "robot")
    result = CliRunner().invoke(app, ["ros2", "node", "--no-warmup"])
    assert_one_line_error(result, "ROS_DOMAIN_ID: got 'robot', expected an integer from 0 to 232")


def test_node_refuses_missing_candidates(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["ros2", "node", "--no-warmup", "--candidates", str(tmp_path / "none.json")])
    assert_one_line_error(result, "none.json")


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (["--rate", "0"], ("--rate: got 0.0, expected a positive number",)),
        (["--tf-delay", "-0.1"], ("--tf-delay: got -0.1",)),
        (["--tf", "a//b"], ("--tf: got 'a//b'",)),
    ],
    ids=["rate", "tf-delay", "topic"],
)
def test_play_refuses_bad_options(args: list[str], fragments: tuple[str, ...]) -> None:
    assert_one_line_error(CliRunner().invoke(app, ["ros2", "play", str(example_session_path()), *args]), *fragments)


def test_play_refuses_a_missing_session(tmp_path: Path) -> None:
    assert_one_line_error(CliRunner().invoke(app, ["ros2", "play", str(tmp_path / "s.json")]), "s.json")
