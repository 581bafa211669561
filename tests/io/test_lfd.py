"""The LfD array layout: round trip on arrays the test writes, one-line errors for bad arrays, the track field."""

from __future__ import annotations

import json
from pathlib import Path

import lfd_scene
import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from monovisual3d import load_session
from monovisual3d.cli import app
from monovisual3d.errors import InputError, InputWarning
from monovisual3d.io.image_size import image_size_from_principal_point
from monovisual3d.io.lfd import read_lfd, read_lfd_arrays
from monovisual3d.io.schema import validate_session_schema
from monovisual3d.truth import load_objects

ALDOMA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "aldoma"


@pytest.fixture
def written(tmp_path: Path) -> tuple[Path, list, np.ndarray]:
    objects, poses = lfd_scene.scene(np.random.default_rng(3), n_objects=3, n_views=5)
    return lfd_scene.write(tmp_path / "lfd", lfd_scene.arrays(objects, poses)), objects, poses


def test_round_trip_pools_the_boxes_sorted_and_recovers_poses_camera_and_truth(written) -> None:
    folder, objects, poses = written
    session, truth = read_lfd(folder)
    cam = lfd_scene.CAMERA
    assert (session.camera.width, session.camera.height) == (640, 480)
    assert_allclose(
        [session.camera.fx, session.camera.fy, session.camera.cx, session.camera.cy], [cam.fx, cam.fy, cam.cx, cam.cy]
    )
    assert_allclose(np.stack([v.T_base_optical for v in session.views]), poses, atol=1e-12)
    for view, T in zip(session.views, poses):
        expected = np.stack([e.bbox(cam, T, clip=False) for e in objects])
        got = view.boxes_xyxy
        assert all(d.track is None for d in view.detections)
        assert np.all(np.diff(got[:, 0]) >= 0)  # sorted by x_min: the order carries no association
        assert_allclose(got, expected[np.argsort(expected[:, 0])], atol=1e-9)
    assert truth is not None and len(truth["objects"]) == 3
    for o, e in zip(truth["objects"], objects):
        assert_allclose(o["position"], e.centre_base, atol=1e-12)
        assert_allclose(np.sort(o["semi_axes"]), np.sort(e.semi_axes), rtol=1e-9)
        R = np.array(o["quaternion_xyzw"])
        from monovisual3d.geometry.ellipsoid import dual_quadric, rotation_from_quaternion_xyzw

        Q = dual_quadric(o["position"], o["semi_axes"], rotation_from_quaternion_xyzw(R))
        assert_allclose(Q, e.dual_quadric(), atol=1e-12)  # same ellipsoid, whatever the order of the axes


def test_the_columns_are_not_in_x_order_so_sorting_changes_the_order(written) -> None:
    folder, objects, poses = written
    session, _ = read_lfd(folder, keep_association=True)
    tracks = [[d.track for d in v.detections] for v in session.views]
    assert all(sorted(t) == [0, 1, 2] for t in tracks)
    assert any(t != [0, 1, 2] for t in tracks) or any(t != tracks[0] for t in tracks)  # the scene makes the test meaningful
    for view, T in zip(session.views, poses):
        for d in view.detections:
            assert_allclose(d.bbox_xyxy, objects[d.track].bbox(lfd_scene.CAMERA, T, clip=False), atol=1e-9)


def test_cli_round_trip_writes_session_and_truth(written, tmp_path: Path) -> None:
    folder, objects, _ = written
    out, truth = tmp_path / "s.json", tmp_path / "t.json"
    res = CliRunner().invoke(app, ["import-lfd", str(folder), "--output", str(out), "--truth", str(truth), "--keep-association"])
    assert res.exit_code == 0, res.output
    session = load_session(out)
    assert [sorted(d.track for d in v.detections) for v in session.views] == [[0, 1, 2]] * 5
    assert validate_session_schema(json.loads(out.read_text())) == []
    objs = load_objects(truth)
    assert objs.has_shapes
    assert_allclose(objs.positions, [e.centre_base for e in objects], atol=1e-12)


def _break(folder: Path, name: str, change) -> None:
    a = np.load(folder / f"{name}.npy")
    np.save(folder / f"{name}.npy", change(a))


def _nan_box(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[2, 4:8] = np.nan  # view 2, object 1, still marked visible
    return a


def _flat_box(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[1, 2] = a[1, 0]  # x_max == x_min
    return a


def _singular_pose(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[4:7] = 0.0  # view 1: R = 0, not invertible
    return a


def _nan_intrinsics(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[0, 2] = np.nan
    return a


def _not_ellipsoid(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[0] = np.diag([0.01, 0.01, -0.01, -1.0])  # a hyperboloid
    return a


BAD = {
    "wrong box columns": ("bounding_boxes", lambda a: a[:, :-1], r"bounding_boxes\.npy: shape \(5, 11\), expected \(5, 12\)"),
    "wrong pose rows": ("camera_poses", lambda a: a[:-4], r"camera_poses\.npy: shape \(16, 3\), expected \(20, 3\)"),
    "NaN intrinsics": ("intrinsics", _nan_intrinsics, r"intrinsics\.npy: entry \(0, 2\) is nan, expected finite"),
    "non-invertible pose": ("camera_poses", _singular_pose, r"camera_poses\.npy: view 1 .*expected a rotation"),
    "visible without a box": ("bounding_boxes", _nan_box, r"bounding_boxes\.npy: view 2, object 1 .*visible"),
    "empty box": ("bounding_boxes", _flat_box, r"bounding_boxes\.npy: view 1, object 0 .*x_min < x_max"),
    "gt not an ellipsoid": ("gt", _not_ellipsoid, r"gt\.npy: object 0: .*not an ellipsoid"),
    "visibility 3d": ("visibility", lambda a: a[None], r"visibility\.npy: shape \(1, 5, 3\), expected \(views, objects\)"),
    "gt wrong count": ("gt", lambda a: a[:2], r"gt\.npy: shape \(2, 4, 4\), expected \(3, 4, 4\)"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_arrays_give_one_line_errors_naming_the_file(written, case: str) -> None:
    folder = written[0]
    name, change, pattern = BAD[case]
    _break(folder, name, change)
    with pytest.raises(InputError, match=pattern) as info:
        read_lfd_arrays(folder)
    assert "\n" not in str(info.value)
    res = CliRunner().invoke(app, ["import-lfd", str(folder), "-o", str(folder / "s.json"), "--truth", str(folder / "t.json")])
    assert res.exit_code == 2
    assert "Traceback" not in res.output and len(res.output.strip().splitlines()) == 1 and "error:" in res.output


def test_invisible_objects_need_no_box_and_gt_is_needed_only_for_truth(written) -> None:
    folder = written[0]
    vis = np.load(folder / "visibility.npy")
    vis[0, 1] = False
    np.save(folder / "visibility.npy", vis)
    _break(folder, "bounding_boxes", _nan_box_view0)
    (folder / "gt.npy").unlink()
    session, truth = read_lfd(folder, truth=False)
    assert [len(v.detections) for v in session.views] == [2, 3, 3, 3, 3] and truth is None
    with pytest.raises(InputError, match=r"gt\.npy: missing, expected"):
        read_lfd(folder)


def _nan_box_view0(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[0, 4:8] = np.nan
    return a


def test_missing_file_and_folder(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not a folder"):
        read_lfd(tmp_path / "nope")
    with pytest.raises(InputError, match=r"visibility\.npy: missing, expected"):
        read_lfd(tmp_path)


def test_image_size_given_or_from_the_principal_point(written) -> None:
    folder = written[0]
    assert (read_lfd(folder, image_size=(800, 600))[0].camera.width, read_lfd(folder)[0].camera.width) == (800, 640)


def test_an_off_centre_principal_point_takes_the_standard_size_and_a_box_past_it_is_truncated(written) -> None:
    """A calibrated principal point lies a few pixels off the centre: the image is still 640 x 480, the assumption is
    said, and a box that the image's right border cuts is clipped there and counts one-sided (with the image taken as
    twice the principal point, 653 px wide, it would be a whole box ending 7 px inside it)."""
    from monovisual3d.methods.bayes.sensor import SensorModel, censored_edges

    folder = written[0]
    K = np.load(folder / "intrinsics.npy")
    K[0, 2], K[1, 2] = 326.2, 233.4  # 2 (c + 0.5) = 653.4 x 467.8
    np.save(folder / "intrinsics.npy", K)
    boxes = np.load(folder / "bounding_boxes.npy")
    boxes[0, 2] = 645.5  # object 0's x_max in view 0: 6 px past the 640 px border (within BOX_OVERHANG_PX)
    np.save(folder / "bounding_boxes.npy", boxes)
    with pytest.warns(InputWarning) as said:
        session, _ = read_lfd(folder)
    text = [str(w.message) for w in said]
    assert any("taking 640x480 (the common sensor size nearest twice the principal point, 653x468)" in t for t in text)
    assert any("clipped to" in t for t in text)
    assert (session.camera.width, session.camera.height) == (640, 480)
    assert_allclose([session.camera.cx, session.camera.cy], [326.7, 233.9])
    cut = session.views[0].boxes_xyxy[np.argmax(session.views[0].boxes_xyxy[:, 2])]
    assert cut[2] == 640.0
    assert censored_edges(cut, 640, 480, SensorModel().border_px).tolist() == [False, False, True, False]


def test_without_a_common_size_the_image_is_twice_the_principal_point_with_a_warning(written) -> None:
    folder = written[0]
    K = np.load(folder / "intrinsics.npy")
    K[0, 2], K[1, 2] = 499.5, 299.5
    np.save(folder / "intrinsics.npy", K)
    with pytest.warns(InputWarning, match=r"taking 1000x600 \(no common sensor size is near twice the principal point"):
        session, _ = read_lfd(folder)
    assert (session.camera.width, session.camera.height) == (1000, 600)


def test_a_given_image_size_is_checked(written) -> None:
    with pytest.raises(InputError, match=r"image_size \(--image-size\): expected \(width, height\)"):
        read_lfd(written[0], image_size=(640, 480, 3))  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("c", "extent", "size"),
    [
        ((320.0, 240.0), (0.0, 0.0), ((640, 480), "exact")),
        ((641.9, 364.2), (0.0, 0.0), ((1280, 720), "standard")),
        ((630.0, 355.0), (0.0, 0.0), ((1280, 720), "standard")),
        ((336.0, 188.0), (0.0, 0.0), ((672, 376), "exact")),  # ZED VGA, not 640 x 360
        ((728.0, 544.0), (0.0, 0.0), ((1456, 1088), "exact")),
        ((364.0, 636.0), (0.0, 0.0), ((720, 1280), "standard")),  # portrait
        ((320.0, 240.0), (645.4, 485.4), ((640, 480), "exact")),  # a box a few pixels past the border
        ((326.0, 184.0), (660.0, 300.0), ((672, 376), "standard")),  # 640 x 360 is nearer but a box reaches 660 px
        ((500.0, 300.0), (0.0, 0.0), ((1000, 600), "principal point")),
    ],
)
def test_image_size_from_principal_point(c, extent, size) -> None:
    assert image_size_from_principal_point(*c, extent) == size


def test_image_size_from_principal_point_rejects_nan() -> None:
    with pytest.raises(InputError, match="principal point .* expected finite"):
        image_size_from_principal_point(float("nan"), 240.0)


# ---------------------------------------------------------------------- the session's track field
def _session(track_values: list) -> dict:
    dets = [{"bbox_xyxy": [100 + 50 * i, 100, 140 + 50 * i, 150], "track": t} for i, t in enumerate(track_values)]
    return {
        "camera": {"width": 640, "height": 480, "hfov_deg": 69},
        "views": [{"pose": {"position": [0, 0, 0], "quaternion_xyzw": [0, 0, 0, 1]}, "detections": dets}],
    }


def test_track_ids_load_and_save() -> None:
    s = load_session(_session([3, 0, None]))
    assert [d.track for d in s.views[0].detections] == [3, 0, None]
    assert [d.get("track") for d in s.to_dict()["views"][0]["detections"]] == [3, 0, None]
    assert validate_session_schema(s.to_dict()) == []


@pytest.mark.parametrize(
    ("values", "pattern"),
    [
        ([-1], r"views\[0\]\.detections\[0\]\.track: expected an object number"),
        ([1.5], r"detections\[0\]\.track: expected an object number"),
        ([True], r"detections\[0\]\.track: expected an object number"),
        (["a"], r"detections\[0\]\.track: expected an object number"),
        ([2, 2], r"views\[0\]\.detections\[1\]\.track: 2 repeats the track of detections\[0\]"),
    ],
)
def test_bad_track_ids_are_one_line_errors(values: list, pattern: str) -> None:
    with pytest.raises(InputError, match=pattern):
        load_session(_session(values))


def test_schema_rejects_what_the_loader_rejects() -> None:
    assert validate_session_schema(_session([-1])) != []
    assert validate_session_schema(_session([1.5])) != []


@pytest.mark.skipif(not (ALDOMA / "bounding_boxes.npy").is_file(), reason="the shared Aldoma set is not here")
def test_the_shared_aldoma_set_reads() -> None:
    with pytest.warns(UserWarning, match="clipped"):  # one box reaches 5 px past the bottom of the image
        session, truth = read_lfd(ALDOMA, keep_association=True)
    assert len(session.views) == 8 and [len(v.detections) for v in session.views] == [6] * 8
    assert truth is not None and len(truth["objects"]) == 6
    sizes = np.array([2 * max(o["semi_axes"]) for o in truth["objects"]])
    assert np.all((sizes > 0.08) & (sizes < 0.25))  # objects 80-240 mm tall
