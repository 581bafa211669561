"""The interactive 3D scene (figures.html3d): what each trace shows, the HTML file, the `view` command, bad inputs."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from monovisual3d import load_session
from monovisual3d.cli import app
from monovisual3d.errors import InputError

pytest.importorskip("plotly")
from html3d_cases import CAM, CENTRES, by_kind, result_dict, truth_dict, two_fruit_session  # noqa: E402

from monovisual3d.figures._style import ESTIMATE_COLOUR  # noqa: E402
from monovisual3d.figures.html3d import (  # noqa: E402
    CHI2_3DOF_95,
    ellipsoid_mesh,
    error_ellipsoid_axes,
    figure_json_from_html,
    fruits_from_dict,
    scene_figure,
    write_scene_html,
)


def test_one_frustum_per_view_one_mesh_per_fruit_and_truth() -> None:
    fig = scene_figure(two_fruit_session(), result_dict(), truth_dict())
    assert [t.meta["view"] for t in by_kind(fig, "frustum")] == [0, 1, 2]
    assert [t.meta["index"] for t in by_kind(fig, "fruit")] == [0, 1, 2]
    assert [t.meta["index"] for t in by_kind(fig, "truth")] == [0, 1]
    assert [t.meta["index"] for t in by_kind(fig, "error_ellipsoid")] == [0]  # only fruit 0 has a covariance
    assert len(by_kind(fig, "workspace")) == 1 and len(by_kind(fig, "base_axes")) == 3
    assert fig.layout.scene.zaxis.title.text == "z (m)" and fig.layout.title.text


def test_boxes_lie_on_the_image_plane_where_the_camera_sees_them() -> None:
    session = load_session(two_fruit_session())
    fig = scene_figure(session, frustum_depth=0.07)
    for t in by_kind(fig, "boxes"):
        view = session.views[t.meta["view"]]
        p = np.array([[x, y, z] for x, y, z in zip(t.x, t.y, t.z) if x is not None])
        T = view.T_base_optical
        p_optical = (p - T[:3, 3]) @ T[:3, :3]
        assert_allclose(p_optical[:, 2], 0.07, atol=1e-9)  # on the image plane at the frustum's depth
        uv = CAM.project(p_optical).reshape(-1, 5, 2)  # 5 points per closed box outline
        for d, corners in zip(view.detections, uv):
            x1, y1, x2, y2 = d.bbox_xyxy
            assert_allclose(corners, [[x1, y1], [x2, y1], [x2, y2], [x1, y2], [x1, y1]], atol=1e-6)


def test_hover_of_a_frustum_names_the_view_and_its_detections() -> None:
    fig = scene_figure(two_fruit_session())
    text = by_kind(fig, "frustum")[1].hovertext  # one text for the whole frustum
    assert "view 1" in text and "2 detection(s)" in text and "#1: [" in text


def test_cones_are_hidden_and_the_menu_shows_one_at_a_time() -> None:
    fig = scene_figure(two_fruit_session())
    (every,) = by_kind(fig, "cones")
    (chosen,) = by_kind(fig, "cone")
    assert every.visible == "legendonly" and every.meta["count"] == 6 and len(chosen.x) == 0
    buttons = fig.layout.updatemenus[0].buttons
    assert len(buttons) == 1 + 6
    chosen_index = next(i for i, t in enumerate(fig.data) if t.meta["kind"] == "cone")
    assert all(list(b.args[1]) == [chosen_index] for b in buttons)  # every entry restyles the one chosen-cone trace
    assert buttons[0].args[0]["x"] == [[]]  # "no viewing cone" empties it
    assert [b.label for b in buttons[1:3]] == ["view 0 box #0", "view 0 box #1"]
    for b in buttons[1:]:  # one cone each: its far rectangle (5 points) and 4 edges, None between lines
        assert sum(v is None for v in b.args[0]["x"][0]) == 5 and len(b.args[0]["x"][0]) == 18


def cone_of(fig: Any, view: int, detection: int) -> np.ndarray:
    """The points of the cone of box ``detection`` of view ``view``, from its menu entry, shape (18, 3) with NaN gaps."""
    (b,) = [b for b in fig.layout.updatemenus[0].buttons if b.label == f"view {view} box #{detection}"]
    return np.array([[np.nan if v is None else v for v in b.args[0][k][0]] for k in "xyz"]).T


def test_cone_passes_through_the_fruit_it_boxes() -> None:
    session = load_session(two_fruit_session())
    fig = scene_figure(session)
    far = cone_of(fig, 0, 1)[:4]  # the far rectangle
    T = session.views[0].T_base_optical
    axis = far.mean(axis=0) - T[:3, 3]
    to_fruit = CENTRES[1] - T[:3, 3]
    cos = axis @ to_fruit / np.linalg.norm(axis) / np.linalg.norm(to_fruit)
    assert cos > np.cos(np.radians(1.0))  # the fruit's centre is on the cone's axis within a degree
    assert np.linalg.norm(axis) > np.linalg.norm(to_fruit)  # and the cone reaches past it
    every = by_kind(fig, "cones")[0]
    points = np.array([[np.nan if v is None else v for v in c] for c in (every.x, every.y, every.z)]).T
    assert np.isclose(points, far[0], atol=1e-12).all(axis=1).any()  # the all-cones trace holds the same cone


def test_fruit_shapes_follow_radius_semi_axes_and_quaternion() -> None:
    res = result_dict()
    fig = scene_figure(two_fruit_session(), res)
    fruit = by_kind(fig, "fruit")
    for t, o in zip(fruit, res["objects"]):
        v = np.column_stack([t.x, t.y, t.z])
        R = Rotation.from_quat(o.get("quaternion_xyzw", [0, 0, 0, 1])).as_matrix()
        a = np.array(o.get("semi_axes") or [o.get("radius", 0.005)] * 3)
        local = (v - o["position"]) @ R / a
        assert_allclose(np.sum(local**2, axis=1), 1.0, atol=1e-9)
        assert t.color == ESTIMATE_COLOUR and t.intensity is None  # one colour, whatever the score
        assert f"score {o['score']:.3g}" in t.hovertemplate and t.meta["score"] == o["score"]
    assert not fig.layout.coloraxis.showscale  # no colour bar to cover the axes


def test_estimates_are_red_numbered_as_in_the_table_and_truth_is_translucent_green() -> None:
    fig = scene_figure(two_fruit_session(), result_dict(), truth_dict())
    (numbers,) = by_kind(fig, "fruit_numbers")
    assert list(numbers.text) == ["<b>0</b>", "<b>1</b>", "<b>2</b>"]  # result.objects[k] is row k of the table
    for k, (x, y) in enumerate(zip(numbers.x, numbers.y)):
        assert_allclose([x, y], result_dict()["objects"][k]["position"][:2], atol=0.03)
    truth = by_kind(fig, "truth")
    assert all(t.color != ESTIMATE_COLOUR and t.opacity < 0.5 for t in truth)
    assert {t.color for t in by_kind(fig, "fruit")} == {ESTIMATE_COLOUR}


def test_error_ellipsoid_is_the_95_percent_contour_of_the_covariance() -> None:
    res = result_dict()
    fig = scene_figure(two_fruit_session(), res)
    (t,) = by_kind(fig, "error_ellipsoid")
    C = np.array(res["objects"][0]["covariance"])
    d = np.column_stack([t.x, t.y, t.z]) - res["objects"][0]["position"]
    assert_allclose(np.einsum("ni,ij,nj->n", d, np.linalg.inv(C), d), CHI2_3DOF_95, rtol=1e-9)


def test_error_lines_join_each_estimate_to_its_matched_truth() -> None:
    fig = scene_figure(two_fruit_session(), result_dict(), truth_dict())
    (t,) = by_kind(fig, "error_lines")
    pts = np.array([[x, y, z] for x, y, z in zip(t.x, t.y, t.z) if x is not None]).reshape(-1, 2, 3)
    lengths = sorted(np.linalg.norm(pts[:, 0] - pts[:, 1], axis=1))
    assert_allclose(lengths, [0.003, 0.004], atol=1e-12)  # fruit 2 (far from both) is left unmatched
    assert "error 3.0 mm" in " ".join(t.hovertext)


def test_mesh_helpers() -> None:
    v, f = ellipsoid_mesh(np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.2, 0.3]), n_lat=6, n_lon=8)
    assert v.shape == (7 * 8, 3) and f.shape == (2 * 6 * 8, 3) and f.max() == len(v) - 1
    a, R = error_ellipsoid_axes(np.array([[2.0, 1.0, 0], [1.0, 2.0, 0], [0, 0, 1.0]]), chi2=1.0)
    assert_allclose(sorted(a**2), [1.0, 1.0, 3.0]) and np.isclose(np.linalg.det(R), 1.0)


def test_html_is_self_contained_and_holds_the_figure(tmp_path: Path) -> None:
    path = write_scene_html(two_fruit_session(), result_dict(), truth_dict(), path=tmp_path / "sub" / "scene.html")
    text = path.read_text()
    assert not re.search(r"<script[^>]*\bsrc=", text)  # no external script: plotly.js is inside, works offline
    assert "plotly.js v" in text[:5000]
    fig = figure_json_from_html(text)
    kinds = [t["meta"]["kind"] for t in fig["data"]]
    assert kinds.count("frustum") == 3 and kinds.count("fruit") == 3 and kinds.count("cones") == 1
    assert fig["layout"]["scene"]["xaxis"]["title"]["text"] == "x (m)"


def test_result_object_and_result_file_give_the_same_figure(tmp_path: Path) -> None:
    from monovisual3d.result import DetectedObject, Result

    obj = DetectedObject(np.array([0.6, 0.0, 0.45]), 5.0, radius=0.03, covariance=np.eye(3) * 1e-6)
    res = Result([obj], "bayes")
    res.to_json(tmp_path / "r.json")
    a = scene_figure(two_fruit_session(), res).to_plotly_json()
    b = scene_figure(two_fruit_session(), tmp_path / "r.json").to_plotly_json()
    assert json.dumps(a, sort_keys=True, default=str) == json.dumps(b, sort_keys=True, default=str)


@pytest.mark.parametrize(
    ("result", "match"),
    [
        ({"objects": "x"}, r"objects: missing field"),
        ({"objects": [{"score": 1}]}, r"objects\[0\]\.position: missing field"),
        ({"objects": [{"position": [0, 0, 0], "radius": -1}]}, r"objects\[0\]\.radius: expected positive metres"),
        ({"objects": [{"position": [0, 0, 0], "semi_axes": [1, 0, 1]}]}, r"objects\[0\]\.semi_axes: expected positive"),
        (
            {"objects": [{"position": [0, 0, 0], "semi_axes": [1, 1, 1], "quaternion_xyzw": [0, 0, 0, 2]}]},
            r"quaternion_xyzw: norm 2",
        ),
        ({"objects": [{"position": [0, 0, 0], "covariance": [[1, 0], [0, 1]]}]}, r"objects\[0\]\.covariance: expected a 3 x 3"),
        ({"objects": [{"position": [0, 0, 0], "associations": {"a": 1}}]}, r"objects\[0\]\.associations\.a: expected view index"),
    ],
)
def test_bad_results_are_rejected_naming_the_field(result: dict[str, Any], match: str) -> None:
    with pytest.raises(InputError, match=match):
        fruits_from_dict(result)


def test_bad_arguments_are_rejected(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"frustum_depth: got -1, expected a positive distance"):
        scene_figure(two_fruit_session(), frustum_depth=-1)
    (tmp_path / "dir.html").mkdir()
    with pytest.raises(InputError, match=r"dir\.html: is a directory"):
        write_scene_html(two_fruit_session(), path=tmp_path / "dir.html")
    with pytest.raises(InputError, match=r"no Plotly\.newPlot"):
        figure_json_from_html("<html></html>")
    bad = tmp_path / "bad.json"
    bad.write_text('{"objects": [{"position": [0, 0]}]}')
    with pytest.raises(InputError, match=r"bad\.json: objects\[0\]\.position: expected 3 numbers, got 2"):
        scene_figure(two_fruit_session(), bad)


def test_view_command(tmp_path: Path) -> None:
    session = tmp_path / "session.json"
    session.write_text(json.dumps(two_fruit_session()))
    (tmp_path / "result.json").write_text(json.dumps(result_dict()))
    (tmp_path / "truth.json").write_text(json.dumps(truth_dict()))
    out = tmp_path / "scene.html"
    runner = CliRunner()
    r = runner.invoke(
        app,
        [
            "view",
            str(session),
            "--result",
            str(tmp_path / "result.json"),
            "--truth",
            str(tmp_path / "truth.json"),
            "-o",
            str(out),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "wrote" in r.output and out.is_file()
    kinds = [t["meta"]["kind"] for t in figure_json_from_html(out.read_text())["data"]]
    assert kinds.count("truth") == 2 and kinds.count("error_lines") == 1
    r = runner.invoke(app, ["view", str(session), "-o", str(tmp_path / "scene.png")])
    assert r.exit_code == 2 and "--output: got" in r.output and "expected a file name ending in .html" in r.output
    r = runner.invoke(app, ["view", str(session), "--result", str(session), "-o", str(out)])
    assert r.exit_code == 2 and "objects: missing field" in r.output


def test_view_without_plotly_names_the_extra(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    session = tmp_path / "session.json"
    session.write_text(json.dumps(two_fruit_session()))
    monkeypatch.setitem(sys.modules, "plotly", None)  # as if the [viz] extra were not installed
    r = CliRunner().invoke(app, ["view", str(session), "-o", str(tmp_path / "s.html")])
    assert r.exit_code == 2 and "pip install 'monovisual3d[viz]'" in r.output


def test_view_open_without_a_browser_says_so(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    session = tmp_path / "session.json"
    session.write_text(json.dumps(two_fruit_session()))
    opened: list[str] = []
    monkeypatch.setattr("webbrowser.open", lambda url: opened.append(url) or False)  # a headless machine: no browser runs
    r = CliRunner().invoke(app, ["view", str(session), "-o", str(tmp_path / "s.html"), "--open"])
    assert r.exit_code == 0 and (tmp_path / "s.html").is_file()
    assert opened == [(tmp_path / "s.html").resolve().as_uri()]
    assert "warning:" in r.output and "no web browser found to open it (--open)" in r.output
