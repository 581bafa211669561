"""Ellipsoid fruit in the simulator: ray casting, scene files, truth, shape presets."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.camera import Camera
from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.geometry import Ellipsoid, ellipsoid_volume, rotation_upright
from monovisual3d.sim import EllipsoidFruit, Scene, Sphere, scene_by_name, shapes_scene, simulate, write_simulation
from monovisual3d.sim.raycast import label_image, label_image_reference, render
from monovisual3d.sim.scene import Leaf
from monovisual3d.sim.scenes import FRUIT_KINDS, default_camera, fruit_of_kind
from monovisual3d.sim.viewpoints import paper_poses

CAM = Camera(64, 48, 50.0, 50.0, 32.0, 24.0)
T = look_at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


def cucumber(centre=(1.0, 0.05, 0.0), yaw: float = 0.5, tilt_deg: float = 12.0) -> EllipsoidFruit:
    from scipy.spatial.transform import Rotation

    R = Rotation.from_euler("x", tilt_deg, degrees=True).as_matrix() @ rotation_upright(yaw)
    return EllipsoidFruit.from_ellipsoid(Ellipsoid.from_rotation(centre, [0.04, 0.03, 0.15], R), "cucumber")


def test_vectorised_ray_cast_equals_the_per_ray_reference_with_ellipsoids() -> None:
    leaf = Leaf(np.array([0.8, 0.1, 0.05]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]), (0.03, 0.02))
    scene = Scene((Sphere(np.array([1.2, -0.2, 0.0]), 0.08), cucumber(), cucumber((1.1, -0.05, -0.1), 1.0, 0.0)), (leaf,))
    fast = label_image(scene, CAM, T, tile=16)
    ref = label_image_reference(scene, CAM, T)
    assert np.array_equal(fast, ref)
    assert set(np.unique(fast)) == {-2, -1, 0, 1, 2}


def test_rendered_box_of_an_ellipsoid_matches_the_conic_box() -> None:
    cam = default_camera()
    fruit = [fruit_of_kind(k, [0.6, y, 0.45], rng=i) for i, (k, y) in enumerate(zip(FRUIT_KINDS, np.linspace(-0.2, 0.2, 5)))]
    scene = Scene(tuple(fruit))
    for pose in paper_poses():
        r = render(scene, cam, pose, supersample=4)
        exact = np.array([f.ellipsoid.bbox(cam, pose) for f in fruit])
        assert_allclose(r.boxes_xyxy, exact, atol=0.5)


def test_ellipsoid_fruit_dict_round_trip_and_truth_fields() -> None:
    f = cucumber()
    d = f.to_dict()
    assert d["shape"] == "ellipsoid" and d["label"] == "cucumber"
    assert_allclose(d["radius"], (0.04 * 0.03 * 0.15) ** (1 / 3))
    assert_allclose(d["volume_m3"], ellipsoid_volume([0.04, 0.03, 0.15]))
    scene = Scene((Sphere(np.array([1.0, 0.3, 0.0]), 0.05), f))
    back = Scene.from_dict(json.loads(json.dumps(scene.to_dict())))
    assert isinstance(back.fruits[1], EllipsoidFruit) and isinstance(back.fruits[0], Sphere)
    assert_allclose(back.fruits[1].rotation, f.rotation, atol=1e-12)
    assert_allclose(back.radii, scene.radii)
    assert "shape" not in back.fruits[0].to_dict()  # sphere truth stays as it was
    default = Scene.from_dict({"objects": [{"position": [1, 0, 0], "semi_axes": [0.03, 0.03, 0.05]}]})
    assert_allclose(default.fruits[0].quaternion_xyzw, [0, 0, 0, 1])


@pytest.mark.parametrize(
    ("obj", "message"),
    [
        ({"position": [1, 0, 0], "semi_axes": [0.03, -0.03, 0.05]}, r"objects\[0\].semi_axes\[1\]: expected a positive"),
        ({"position": [1, 0, 0], "semi_axes": [0.03, 0.05]}, r"objects\[0\].semi_axes: expected 3 numbers, got 2"),
        ({"position": [1, 0, 0], "semi_axes": [0.03, 0.03, 0.05], "quaternion_xyzw": [0, 0, 0, 3]}, r"quaternion_xyzw: norm"),
        ({"semi_axes": [0.03, 0.03, 0.05]}, r"objects\[0\].position: missing field"),
        ({"position": [1, 0, 0], "semi_axes": [0.03, 0.03, 0.05], "label": 3}, r"objects\[0\].label: expected a string"),
    ],
)
def test_bad_ellipsoid_fruit_is_rejected(obj: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        Scene.from_dict({"objects": [obj]})


@pytest.mark.parametrize("name", ["peppers", "cucumbers", "apples", "mixed"])
def test_shape_presets_are_visible_in_every_paper_view(name: str) -> None:
    scene = scene_by_name(name, rng=3)
    assert scene.name == name and all(isinstance(f, EllipsoidFruit) for f in scene.fruits)
    assert len(scene.fruits) == (4 if name == "cucumbers" else 6)
    session, truth = simulate(scene, rng=0)
    assert [len(v.detections) for v in session.views] == [len(scene.fruits)] * 3
    for o, f in zip(truth["objects"], scene.fruits):
        assert set(o) >= {"position", "radius", "shape", "semi_axes", "quaternion_xyzw", "volume_m3", "label"}
        (a_lo, a_hi), _, (c_lo, c_hi), relative, tilt_deg = FRUIT_KINDS[f.label]
        a, b, c = f.semi_axes
        assert a_lo <= a <= a_hi and b <= a
        assert (c_lo * a if relative else c_lo) - 1e-12 <= c <= (c_hi * a if relative else c_hi) + 1e-12
        tilt = np.degrees(np.arccos(np.clip(f.rotation[2, 2], -1, 1)))
        assert tilt <= tilt_deg + 1e-9
    if name == "mixed":
        assert {f.label for f in scene.fruits} == {"tomato", "pepper", "cucumber", "apple", "plum"}
    # the same seed gives the same scene
    assert scene.to_dict() == scene_by_name(name, rng=3).to_dict()


def test_cucumbers_are_tall_and_tilted_up_to_15_degrees() -> None:
    tilts, ratios = [], []
    for seed in range(40):
        f = fruit_of_kind("cucumber", [0.6, 0.0, 0.45], rng=seed)
        tilts.append(np.degrees(np.arccos(f.rotation[2, 2])))
        ratios.append(f.semi_axes[2] / f.semi_axes[0])
    assert max(tilts) <= 15.0 and max(tilts) > 10.0
    assert min(ratios) > 3.0


def test_write_simulation_truth_carries_shapes(tmp_path) -> None:
    paths = write_simulation(tmp_path / "sim", shapes_scene("cucumbers", rng=1), images=False)
    truth = json.loads(paths["truth"].read_text())
    o = truth["objects"][0]
    assert o["shape"] == "spheroid" and len(o["semi_axes"]) == 3 and len(o["quaternion_xyzw"]) == 4
    assert_allclose(o["volume_m3"], 4 / 3 * np.pi * np.prod(o["semi_axes"]))
    assert_allclose(o["radius"], np.cbrt(np.prod(o["semi_axes"])))
    assert isinstance(Scene.load(paths["scene"]).fruits[0], EllipsoidFruit)


def test_shape_scene_bad_input() -> None:
    with pytest.raises(InputError, match="scene: got 'bananas'"):
        shapes_scene("bananas")
    with pytest.raises(InputError, match="kind: got 'banana'"):
        fruit_of_kind("banana", [0, 0, 0])
    with pytest.raises(InputError, match="n_fruit: got 13"):
        shapes_scene("mixed", n_fruit=13)
    with pytest.raises(InputError, match="no arrangement of 12 fruit in 2 attempts"):
        shapes_scene("apples", rng=0, n_fruit=12, max_attempts=2)
    with pytest.raises(InputError, match="expected one of .*mixed"):
        scene_by_name("bananas")


def test_cli_simulate_shape_scene(tmp_path) -> None:
    from typer.testing import CliRunner

    from monovisual3d.cli import app

    out = tmp_path / "cuc"
    result = CliRunner().invoke(app, ["simulate", "--scene", "cucumbers", "--n-fruit", "3", "--no-images", "-o", str(out)])
    assert result.exit_code == 0, result.output
    truth = json.loads((out / "truth.json").read_text())
    assert len(truth["objects"]) == 3 and {o["label"] for o in truth["objects"]} == {"cucumber"}
    assert all(o["semi_axes"][2] > 0.07 for o in truth["objects"])
    bad = CliRunner().invoke(app, ["simulate", "--scene", "bananas", "-o", str(out)])
    assert bad.exit_code == 2 and "mixed" in bad.output
