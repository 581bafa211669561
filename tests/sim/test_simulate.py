"""simulate / write_simulation: sessions that load, truth that matches, seeds, and a localisation check."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import monovisual3d
from monovisual3d import load_session
from monovisual3d.errors import InputError
from monovisual3d.session import Workspace
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.raycast import render
from monovisual3d.sim.scene import Leaf, Scene, Sphere
from monovisual3d.sim.scenes import default_camera, paper_scene, random_scene
from monovisual3d.sim.simulate import simulate, simulate_views, view_image, write_png, write_simulation
from monovisual3d.sim.viewpoints import paper_poses, ring_poses
from monovisual3d.truth import load_objects

CAM = default_camera()


def test_noiseless_paper_simulation_reports_the_exact_visible_boxes():
    scene = paper_scene()
    session, truth = simulate(scene, rng=0)
    P = paper_poses()
    assert len(session.views) == 3
    for view, T in zip(session.views, P):
        assert_array_equal(view.T_base_optical, T)
        assert_array_equal(view.boxes_xyxy, render(scene, CAM, T).boxes_xyxy)
        assert all(d.label == "tomato" for d in view.detections)
    assert_allclose(load_objects(truth).positions, scene.centres)
    assert truth["views"][0]["detection_fruit"] == list(range(6))
    assert truth["noise"]["box_sigma"] == 0.0 and truth["scene"]["name"] == "paper"


def test_session_round_trip_through_json(tmp_path):
    scene = random_scene(4, rng=2)
    noise = NoiseModel(box_sigma=0.05, drop_probability=0.1, false_positive_rate=0.5, pose_position_std=0.003)
    session, _ = simulate(scene, CAM, ring_poses(n=4), noise=noise, rng=1, workspace=Workspace(np.zeros(3), np.ones(3)))
    path = tmp_path / "s.json"
    session.to_json(path)
    loaded = load_session(path)
    assert loaded.camera == session.camera
    assert loaded.workspace is not None
    assert len(loaded.views) == len(session.views) == 4
    for a, b in zip(loaded.views, session.views):
        assert_allclose(a.T_base_optical, b.T_base_optical, atol=1e-12)
        assert_allclose(a.boxes_xyxy, b.boxes_xyxy)
    from_dict = load_session(session.to_dict())
    assert [len(v.detections) for v in from_dict.views] == [len(v.detections) for v in session.views]


def test_detections_are_tracked_to_their_fruit():
    scene = Scene(
        (Sphere(np.array([0.6, 0.0, 0.45]), 0.04), Sphere(np.array([0.6, -0.15, 0.45]), 0.04)),
        (Leaf(np.array([0.45, 0.0, 0.45]), np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, -1.0]), (0.06, 0.06)),),
        metadata={"target": [0.6, 0.0, 0.45]},
    )
    session, truth = simulate(scene, CAM, paper_poses()[:1], rng=0)
    assert truth["views"][0]["visible_bbox_xyxy"][0] is None  # fruit 0 is behind the leaf
    assert truth["views"][0]["detection_fruit"] == [1]
    assert len(session.views[0].detections) == 1


def test_pose_error_changes_the_reported_pose_not_the_image():
    scene = paper_scene()
    exact, _ = simulate(scene, rng=0)
    noise = NoiseModel.from_mm_deg(pose_error_mm=5.0, pose_error_deg=1.0)
    noisy, truth = simulate(scene, noise=noise, rng=0)
    for a, b, tv in zip(exact.views, noisy.views, truth["views"]):
        assert_array_equal(a.boxes_xyxy, b.boxes_xyxy)  # rendered from the true pose
        assert not np.allclose(a.T_base_optical, b.T_base_optical)
        assert_array_equal(np.array(tv["T_base_optical_true"]), a.T_base_optical)
        assert_array_equal(np.array(tv["T_base_optical_reported"]), b.T_base_optical)
        assert 0 < np.linalg.norm(b.T_base_optical[:3, 3] - a.T_base_optical[:3, 3]) < 0.05


def test_box_noise_is_relative_to_the_box_size():
    scene = paper_scene()
    cam = CAM.scaled(320, 240)
    exact, _ = simulate(scene, cam, rng=0)
    rel = []
    for seed in range(20):
        noisy, truth = simulate(scene, cam, noise=NoiseModel(box_sigma=0.05), rng=seed)
        for a, b in zip(exact.views, noisy.views):
            size = a.boxes_xyxy[:, 2:] - a.boxes_xyxy[:, :2]
            centre_shift = 0.5 * (b.boxes_xyxy[:, :2] + b.boxes_xyxy[:, 2:] - a.boxes_xyxy[:, :2] - a.boxes_xyxy[:, 2:])
            rel.append(centre_shift / size)
    rel = np.concatenate(rel)
    assert_allclose(rel.std(axis=0), 0.05, rtol=0.15)  # 360 samples per axis


def test_same_seed_same_session_and_different_seed_different_session():
    noise = NoiseModel.paper(false_positive_rate=0.3, pose_position_std=0.002)
    a = simulate(paper_scene(), noise=noise, rng=11)
    b = simulate(paper_scene(), noise=noise, rng=11)
    c = simulate(paper_scene(), noise=noise, rng=12)
    assert a[0].to_json() == b[0].to_json() and json.dumps(a[1]) == json.dumps(b[1])
    assert a[0].to_json() != c[0].to_json()
    rng = np.random.default_rng(5)  # a Generator is consumed: two runs from it differ
    assert (
        simulate(paper_scene(), noise=noise, rng=rng)[0].to_json() != simulate(paper_scene(), noise=noise, rng=rng)[0].to_json()
    )


def test_write_simulation_files(tmp_path):
    out = tmp_path / "run"
    paths = write_simulation(out, paper_scene(), noise=NoiseModel.paper(), rng=0)
    assert set(paths) == {"session", "truth", "scene", "view_00", "view_01", "view_02"}
    session = monovisual3d.load_session(paths["session"])
    assert [v.image for v in session.views] == ["view_00.png", "view_01.png", "view_02.png"]
    assert_allclose(load_objects(paths["truth"]).positions, paper_scene().centres)
    assert Scene.load(paths["scene"]).to_dict() == paper_scene().to_dict()
    png = paths["view_00"].read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert (width, height) == (640, 480)  # the bare camera picture (figures: tests/figures/test_views.py)
    no_images = write_simulation(tmp_path / "plain", paper_scene(), images=False)
    assert set(no_images) == {"session", "truth", "scene"}
    assert all(v.image is None for v in load_session(no_images["session"]).views)


def test_written_png_decodes_to_the_same_pixels(tmp_path):
    cv2 = pytest.importorskip("cv2")
    view = simulate_views(paper_scene(), CAM.scaled(160, 120), rng=0)[0]
    img = view_image(view)
    assert img.shape == (120, 160, 3) and img.dtype == np.uint8
    write_png(tmp_path / "a.png", img)
    back = cv2.imread(str(tmp_path / "a.png"), cv2.IMREAD_COLOR)[:, :, ::-1]
    assert_array_equal(back, img)


def test_view_image_draws_thick_blue_boxes_numbered_by_detection_index():
    from monovisual3d.sim.raycast import BACKGROUND, Rendering
    from monovisual3d.sim.simulate import BOX_COLOUR, FALSE_POSITIVE_COLOUR, TAG_TEXT_COLOUR, SimulatedView

    labels = np.full((120, 160), BACKGROUND, dtype=np.int32)
    labels[40:80, 30:70] = 0  # one red fruit under the first box
    boxes = np.array([[30.0, 40, 70, 80], [100, 60, 150, 110]])
    rendering = Rendering(labels, boxes[:1], np.array([1600.0]))
    view = SimulatedView(np.eye(4), np.eye(4), rendering, boxes, np.array([0, -1]))
    img = view_image(view)
    # 2 px lines inside the box edges, in blue; the fruit shows inside them
    for x1, y1, x2, y2 in boxes.astype(int)[:1]:
        assert (img[y1 + 20, x1 : x1 + 2] == BOX_COLOUR).all() and (img[y1 + 20, x2 - 2 : x2] == BOX_COLOUR).all()
        assert (img[y2 - 2 : y2, x1 + 20] == BOX_COLOUR).all()
        assert not (img[y1 + 20, x1 + 2] == BOX_COLOUR).all() and not (img[y1 + 20, x1 - 1] == BOX_COLOUR).all()
        assert img[60, 50].tolist() == img[y1 + 20, x1 + 2].tolist() and img[60, 50, 0] > 150  # red fruit
    assert (img[85, 149] == FALSE_POSITIVE_COLOUR).all()
    # the index tag above each box's top-left corner: "0" is a ring of white font dots, "1" a vertical stroke
    tag0 = img[40 - 12 : 40, 30 : 30 + 8]
    assert (tag0 == TAG_TEXT_COLOUR).all(axis=-1).sum() == 12 * 4  # 12 dots of the 3x5 "0", 2x2 pixels each
    tag1 = img[60 - 12 : 60, 100 : 100 + 8]
    assert (tag1 == TAG_TEXT_COLOUR).all(axis=-1).sum() == 8 * 4  # 8 dots of the 3x5 "1"
    assert (tag1 == FALSE_POSITIVE_COLOUR).all(axis=-1).any()


def test_bad_inputs_are_rejected(tmp_path):
    with pytest.raises(InputError, match="scene: expected a Scene"):
        simulate({"objects": []})
    with pytest.raises(InputError, match="noise: expected a NoiseModel"):
        simulate(paper_scene(), noise=0.05)
    with pytest.raises(InputError, match=r"poses: expected shape \(N, 4, 4\)"):
        simulate(paper_scene(), poses=np.zeros((3, 3)))
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="exists and is not a directory"):
        write_simulation(tmp_path / "file", paper_scene())


def test_paper_method_localises_one_paper_sphere_within_10_mm():
    sphere = paper_scene().fruits[1]  # a 5 cm sphere of the paper scene
    scene = Scene((sphere,), metadata=paper_scene().metadata)
    session, truth = simulate(scene, rng=0)
    result = monovisual3d.localize(session, method="paper", resolution=0.01)
    assert len(result.objects) == 1
    error = np.linalg.norm(result.objects[0].position - sphere.centre)
    assert error < 0.010
