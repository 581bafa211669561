"""The interactive 3D scene (viz3d): what each trace shows, the HTML file, the `view` command, bad inputs."""

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

from monovisual3d import Camera, load_session
from monovisual3d.cli import app
from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.geometry.sphere import sphere_bbox

pytest.importorskip("plotly")
from monovisual3d.viz3d import (  # noqa: E402
    CHI2_3DOF_95,
    ellipsoid_mesh,
    error_ellipsoid_axes,
    figure_json_from_html,
    fruits_from_dict,
    scene_figure,
    write_scene_html,
)

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
    text = by_kind(fig, "frustum")[1].hovertext[0]
    assert "view 1" in text and "2 detection(s)" in text and "#1: [" in text


def test_every_cone_is_hidden_and_the_menu_shows_one_at_a_time() -> None:
    fig = scene_figure(two_fruit_session())
    cones = by_kind(fig, "cone")
    assert len(cones) == 6 and all(t.visible == "legendonly" for t in cones)
    buttons = fig.layout.updatemenus[0].buttons
    assert len(buttons) == 1 + len(cones)
    assert all(v == "legendonly" for v in buttons[0].args[0]["visible"])
    for b in buttons[1:]:
        assert sum(v is True for v in b.args[0]["visible"]) == 1
    cone_ids = [i for i, t in enumerate(fig.data) if t.meta["kind"] == "cone"]
    assert list(buttons[1].args[1]) == cone_ids


def test_cone_passes_through_the_fruit_it_boxes() -> None:
    session = load_session(two_fruit_session())
    fig = scene_figure(session)
    cone = next(t for t in by_kind(fig, "cone") if t.meta["view"] == 0 and t.meta["detection"] == 1)
    far = np.array([[x, y, z] for x, y, z in zip(cone.x[:4], cone.y[:4], cone.z[:4])])  # the far rectangle
    T = session.views[0].T_base_optical
    axis = far.mean(axis=0) - T[:3, 3]
    to_fruit = CENTRES[1] - T[:3, 3]
    cos = axis @ to_fruit / np.linalg.norm(axis) / np.linalg.norm(to_fruit)
    assert cos > np.cos(np.radians(1.0))  # the fruit's centre is on the cone's axis within a degree
    assert np.linalg.norm(axis) > np.linalg.norm(to_fruit)  # and the cone reaches past it


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
        assert set(np.asarray(t.intensity)) == {o["score"]}  # coloured by score
    assert (fig.layout.coloraxis.cmin, fig.layout.coloraxis.cmax) == (2.0, 20.0)


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
    assert kinds.count("frustum") == 3 and kinds.count("fruit") == 3
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
