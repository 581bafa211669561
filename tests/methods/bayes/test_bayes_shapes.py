"""The shape stage of ``bayes``: spheroids and ellipsoids, the auto choice, and the shape options."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

import monovisual3d as mv
from monovisual3d.cli import app
from monovisual3d.errors import InputError, InputWarning
from monovisual3d.geometry.ellipsoid import Ellipsoid, rotation_upright
from monovisual3d.methods.bayes import BayesConfig
from monovisual3d.methods.bayes.aspects import (
    ROUNDNESS_THRESHOLD,
    aspect_deviations,
    consistently_elongated,
    elongated_one_way,
    looks_round,
    possibly_cut,
    sticks_out,
)
from monovisual3d.methods.bayes.fits import lowest_bic_fit
from monovisual3d.methods.bayes.problem import Problem, build_problem
from monovisual3d.methods.bayes.shapes import fit_shape
from monovisual3d.methods.bayes.state import Found
from monovisual3d.session import Detection, Session, View, Workspace
from monovisual3d.sim.scenes import default_camera, paper_scene
from monovisual3d.sim.simulate import simulate
from monovisual3d.sim.viewpoints import paper_poses

CAM = default_camera()
WS = Workspace(np.array([0.3, -0.3, 0.2]), np.array([0.9, 0.3, 0.8]))


def _session(ellipsoids: list[Ellipsoid]) -> Session:
    views = []
    for T in paper_poses():
        dets = tuple(Detection(np.asarray(e.bbox(CAM, T), dtype=float)) for e in ellipsoids)
        views.append(View(np.asarray(T), dets))
    return Session(CAM, tuple(views), WS)


def test_a_tall_box_from_three_views_is_one_spheroid():
    # semi-axes 20 x 20 x 60 mm: boxes about 1:3 in every view
    true = Ellipsoid.spheroid([0.6, 0.0, 0.5], 0.02, 0.06)
    r = mv.localize(_session([true]))
    assert len(r.objects) == 1
    o = r.objects[0]
    assert o.shape == "spheroid"
    assert np.linalg.norm(o.position - true.centre_base) < 1.5e-3
    assert_allclose(np.sort(o.semi_axes), [0.02, 0.02, 0.06], atol=2e-3)


#: A 12 x 5 x 5 cm object on its side (a can, a box, a cucumber lying down), long axis horizontal.
LYING = (0.06, 0.025, 0.025)


@pytest.mark.parametrize("yaw", [1.0, 2.0])
def test_a_lying_object_from_three_views_is_an_ellipsoid(yaw):
    # the paper's views all see it wider than a sphere; an oblate upright spheroid leaves 2.6-2.9 mm of centre error,
    # the ellipsoid none. (Seen exactly broadside from all three views, yaw 1.5, the spheroid's boxes stay within the
    # sensor model's noise, the BIC keeps it, and it lands 4.4 mm off.)
    true = Ellipsoid.from_rotation([0.6, 0.0, 0.5], LYING, rotation_upright(yaw))
    r = mv.localize(_session([true]))
    assert len(r.objects) == 1
    o = r.objects[0]
    assert o.shape == "ellipsoid"
    assert np.linalg.norm(o.position - true.centre_base) < 1e-3
    assert_allclose(np.sort(o.semi_axes), np.sort(LYING), atol=2e-3)


def _object_at(e: Ellipsoid, radius: float) -> tuple[Problem, Found]:
    """The problem of ``_session([e])`` and a sphere estimate of radius ``radius`` at ``e``'s centre holding its boxes."""
    session = _session([e])
    problem = build_problem(CAM, BayesConfig(), session.views)
    return problem, Found(e.centre_base, 10.0, radius, associations={v: 0 for v in range(len(session.views))})


def test_aspect_deviations_say_upright_lying_or_round():
    problem, upright = _object_at(Ellipsoid.spheroid([0.6, 0.0, 0.5], 0.02, 0.06), 0.02)
    d = aspect_deviations(problem, upright)
    assert len(d) == 3 and np.all(d > ROUNDNESS_THRESHOLD) and not looks_round(problem, upright)
    assert elongated_one_way(d)  # taller than a sphere in every view
    problem, lying = _object_at(Ellipsoid.from_rotation([0.6, 0.0, 0.5], LYING, rotation_upright(0.5)), 0.035)
    d = aspect_deviations(problem, lying)
    assert np.any(d < -ROUNDNESS_THRESHOLD) and np.any(d > ROUNDNESS_THRESHOLD)  # wide in one view, tall in another
    assert not looks_round(problem, lying) and not elongated_one_way(d)
    assert fit_shape(problem, lying).shape == "ellipsoid"
    problem, ball = _object_at(Ellipsoid.sphere([0.6, 0.0, 0.5], 0.03), 0.03)
    assert_allclose(aspect_deviations(problem, ball), 0.0, atol=1e-9)
    assert looks_round(problem, ball)


def _cut(session: Session, cuts: dict[int, tuple[int, float]]) -> list[View]:
    """The views of ``session`` with box edge ``e`` of view ``v`` moved inward by ``f`` of the box size ({v: (e, f)})."""
    views = list(session.views)
    for v, (edge, fraction) in cuts.items():
        box = np.asarray(views[v].detections[0].bbox_xyxy, dtype=float)
        size = box[2 + edge % 2] - box[edge % 2]
        box[edge] += fraction * size * (1 if edge < 2 else -1)
        views[v] = View(views[v].T_base_optical, (Detection(box),))
    return views


def test_one_truncated_box_does_not_make_a_sphere_elongated():
    views = _cut(_session([Ellipsoid.sphere([0.6, 0.0, 0.5], 0.03)]), {1: (2, 0.4)})  # a leaf hides 40 % in one view
    problem = build_problem(CAM, BayesConfig(), views)
    obj = Found(np.array([0.6, 0.0, 0.5]), 10.0, 0.03, associations={0: 0, 1: 0, 2: 0})
    assert np.sum(np.abs(aspect_deviations(problem, obj)) > ROUNDNESS_THRESHOLD) == 1
    assert looks_round(problem, obj)


def test_a_sphere_cut_wide_in_one_view_and_tall_in_another_stays_a_sphere():
    # leaves hide its top in view 0 and its right side in view 2: elongated both ways, as a lying object is, but
    # the sensor model explains the two cut boxes as occlusion and no shape beats the sphere there
    true = Ellipsoid.sphere([0.6, 0.0, 0.5], 0.03)
    views = _cut(_session([true]), {0: (1, 0.35), 2: (2, 0.35)})
    problem = build_problem(CAM, BayesConfig(), views)
    obj = Found(true.centre_base, 10.0, 0.03, associations={0: 0, 1: 0, 2: 0})
    d = aspect_deviations(problem, obj)
    assert not looks_round(problem, obj) and not elongated_one_way(d)
    o = fit_shape(problem, obj)
    assert o.shape == "sphere"
    assert_allclose(o.position, true.centre_base, atol=1e-12)  # the sphere estimate itself


def test_a_sphere_cut_to_tall_slivers_by_neighbours_or_leaves_stays_a_sphere():
    """In a dense row nearer fruit, in a greenhouse leaves, cut a fruit's boxes on the side: the boxes are tall, and an
    upright spheroid fits them (9 mm off here). With those views flagged as cut by nearer objects (occlusion_flags),
    or with an edge far inside the sphere's prediction (possibly_cut: an occluder the search does not see) and boxes
    elongated unlike each other (a cut changes only the boxes it cuts), the fitted shape must beat the sphere under the
    sensor model, which scores the cut edges as occlusion: it does not, and the fruit stays the sphere. (Cuts of 20 %
    or less still give the spheroid: within the edge noise, the sensor model cannot tell.)"""
    true = Ellipsoid.sphere([0.6, 0.0, 0.5], 0.03)
    obj = Found(true.centre_base, 10.0, 0.03, associations={0: 0, 1: 0, 2: 0})
    alike = _cut(_session([true]), {0: (0, 0.3), 1: (2, 0.3), 2: (0, 0.3)})  # 30 % of the width hidden, one side
    problem = build_problem(CAM, BayesConfig(), alike)
    assert elongated_one_way(aspect_deviations(problem, obj)) and possibly_cut(problem, obj)
    # the sensor model's test is what keeps the sphere: the best fit alone takes the slivers at face value
    best = lowest_bic_fit(problem, obj, ("sphere", "spheroid"))
    assert best is not None and best[0][0].shape == "spheroid"
    o = fit_shape(problem, obj, cut=frozenset({0, 1, 2}))
    assert o.shape == "sphere"
    assert_allclose(o.position, true.centre_base, atol=1e-12)
    # unflagged, cuts alike in every view look like an upright object's boxes, and the fit is taken
    assert fit_shape(problem, obj).shape == "spheroid"
    # a leaf's cuts differ from view to view: unflagged, the sensor model's test applies
    unlike = build_problem(CAM, BayesConfig(), _cut(_session([true]), {0: (0, 0.6), 1: (2, 0.25), 2: (0, 0.25)}))
    d = aspect_deviations(unlike, obj)
    assert elongated_one_way(d) and not consistently_elongated(d) and possibly_cut(unlike, obj)
    assert lowest_bic_fit(unlike, obj, ("sphere", "spheroid"))[0][0].shape == "spheroid"  # type: ignore[index]
    o = fit_shape(unlike, obj)
    assert o.shape == "sphere"
    assert_allclose(o.position, true.centre_base, atol=1e-12)


def test_a_cucumber_found_as_a_large_sphere_takes_its_shape():
    """A tall object the search found as a sphere of its height: the boxes lie far inside that sphere's on both sides
    (possibly_cut), which the sensor model would explain as occlusion nearly as well as the fitted shape explains them.
    But they are elongated alike in every view, as an object is and cuts are not (consistently_elongated): the fit is
    taken without that test."""
    true = Ellipsoid.spheroid([0.6, 0.0, 0.5], 0.021, 0.09)
    problem, obj = _object_at(true, 0.08)
    d = aspect_deviations(problem, obj)
    assert possibly_cut(problem, obj) and consistently_elongated(d)
    o = fit_shape(problem, obj)
    assert o.shape == "spheroid"
    assert_allclose(o.position, true.centre_base, atol=2e-3)


def test_a_container_cut_in_one_view_takes_its_shape_from_the_others_under_pose_error():
    """Seed 1600 of ``experiments/container_pairs.py ... --pose-error=3,0.5``, views 0, 2, 6 (two containers and a tray,
    each reported pose off by 3 mm and 0.5 degrees per axis). One container's box in one view is cut by the other
    container; its other two boxes are elongated alike, as the container is. A sphere 38 mm off explained the
    pose-shifted edges of those views as cuts better than the spheroid did, and was kept: the boxes no nearer object
    cuts now show the shape, and the container is a spheroid 8 mm off (the pose error's own share)."""
    from pathlib import Path

    from monovisual3d.truth import load_objects

    data = Path(__file__).parent / "data"
    session = mv.load_session(data / "pose_error_pair.session.json")
    truth = load_objects(data / "pose_error_pair.truth.json").positions
    with pytest.warns(InputWarning, match=r"views\[1\]: the boxes of its 3 objects .* may be off"):  # views 0.7-1.6 deg off
        result = mv.localize(session, size_range=(0.02, 0.15))
    off = 1e3 * np.linalg.norm(result.positions[:, None] - truth[None], axis=2)
    nearest = off.argmin(axis=0)
    assert off[nearest[0], 0] < 12, off.min(axis=0)
    assert result.objects[nearest[0]].shape == "spheroid"
    assert off.min(axis=0)[1:].max() < 20, off.min(axis=0)


def test_an_uncut_upright_object_is_not_taken_as_possibly_cut():
    """A tall spheroid's exact boxes: its volume-equivalent sphere's boxes stick out at the sides by less than the
    occlusion threshold, and the object takes its fitted shape without the sensor-model test."""
    true = Ellipsoid.spheroid([0.6, 0.0, 0.5], 0.025, 0.04)
    problem, obj = _object_at(true, float((0.025 * 0.025 * 0.04) ** (1 / 3)))
    assert not possibly_cut(problem, obj)
    o = fit_shape(problem, obj)
    assert o.shape == "spheroid"
    assert_allclose(o.position, true.centre_base, atol=1e-3)


def test_lying_containers_from_three_views_are_found_where_they_are():
    """12 x 5 x 5 cm on its side, three views over 120 degrees at 0.6 m, 1280 x 720, 2 % box noise, fresh seeds.

    Before lying objects got the ellipsoid, 3 of these 20 came within 5 mm (median 33 mm): a sphere or an upright
    spheroid fitted to a lying object's boxes lands off its centre. Before the search had lying bins
    (``lying_yaws``), 3 of these seeds gave no object: spheres' and upright spheroids' boxes do not match a lying
    object's wide box. Now every seed is found.
    """
    from monovisual3d.camera import Camera
    from monovisual3d.frames import look_at
    from monovisual3d.sim.noise import NoiseModel
    from monovisual3d.sim.scene import EllipsoidFruit, Scene

    cam, target = Camera.from_hfov(1280, 720, 69.0), np.array([0.6, 0.0, 0.3])
    errors = []
    for seed in range(20):
        rng = np.random.default_rng(3000 + seed)
        centre = target + rng.uniform(-0.02, 0.02, 3)
        elevation = np.radians(rng.uniform(0.0, 30.0))
        directions = [
            [-np.cos(elevation) * np.cos(az), np.cos(elevation) * np.sin(az), np.sin(elevation)]
            for az in np.radians([-60.0, 0.0, 60.0])
        ]
        poses = np.array([look_at(target + 0.6 * np.array(d), target + rng.uniform(-0.02, 0.02, 3)) for d in directions])
        e = Ellipsoid.from_rotation(centre, LYING, rotation_upright(rng.uniform(0.0, np.pi)))
        scene = Scene((EllipsoidFruit.from_ellipsoid(e),))
        workspace = Workspace(target - 0.2, target + 0.2)
        session, _ = simulate(scene, cam, poses, noise=NoiseModel(box_sigma=0.02), rng=rng, workspace=workspace)
        with warnings.catch_warnings():  # a seed the search misses warns that no object is consistent: counted below
            warnings.simplefilter("ignore", InputWarning)
            objects = mv.localize(session).objects
        errors.append(min((np.linalg.norm(o.position - centre) for o in objects), default=np.inf))
    errors = np.array(errors)
    assert np.all(np.isfinite(errors)), np.round(errors * 1e3, 1)
    assert np.sum(errors < 0.005) >= 10, np.round(errors * 1e3, 1)
    assert np.all(errors[np.isfinite(errors)] < 0.012), np.round(errors * 1e3, 1)


def test_auto_keeps_the_paper_spheres_spheres():
    session, _ = simulate(paper_scene(), rng=0)
    r = mv.localize(session)
    assert len(r.objects) == 6 and {o.shape for o in r.objects} == {"sphere"}
    assert all(np.ptp(o.semi_axes) == 0 for o in r.objects)


def test_a_sphere_fitted_as_an_ellipsoid_has_equal_semi_axes():
    true = Ellipsoid.sphere([0.62, 0.02, 0.48], 0.03)
    o = mv.localize(_session([true]), shape="ellipsoid").objects[0]
    assert o.shape == "ellipsoid"
    assert np.ptp(o.semi_axes) < 1e-3 and abs(float(np.mean(o.semi_axes)) - 0.03) < 1e-3


def test_shape_sphere_is_the_sphere_model():
    true = Ellipsoid.spheroid([0.6, 0.0, 0.5], 0.02, 0.05)
    o = mv.localize(_session([true]), shape="sphere").objects[0]
    assert o.shape == "sphere" and np.ptp(o.semi_axes) == 0


def test_size_range_sets_the_search_radii_and_up_is_normalised():
    cfg = BayesConfig(size_range="0.02,0.12", up="0,0,2")
    assert (cfg.radius_min, cfg.radius_max) == (0.02, 0.12) and cfg.semi_axis_range == (0.005, 0.12)
    assert BayesConfig(size_range="0.003,0.05").semi_axis_range == (0.003, 0.05)
    assert BayesConfig().semi_axis_range == (0.005, 0.16) and BayesConfig(radius_max=0.3).semi_axis_range == (0.005, 0.3)
    assert cfg.up == (0.0, 0.0, 1.0)
    assert BayesConfig(size_range=(0.01, 0.05)).to_dict()["size_range"] == [0.01, 0.05]


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"size_range": "0.1,0.05"}, r"^size_range: got 0.1,0.05, expected 0 < MIN < MAX \(semi-axis length, metres\)$"),
        ({"size_range": "-0.01,0.05"}, r"^size_range: got -0.01,0.05, expected 0 < MIN < MAX"),
        ({"size_range": "0.01"}, r"^size_range: got '0.01', expected MIN,MAX in metres"),
        ({"up": "0,0,0"}, r"^up: got \[0.0, 0.0, 0.0\], expected a vector of non-zero length"),
        ({"up": "a,b,c"}, r"^up: got 'a,b,c', expected three numbers"),
        ({"shape": "cube"}, r"^shape: got 'cube', expected one of \['auto', 'sphere', 'spheroid', 'ellipsoid'\]$"),
    ],
)
def test_bad_shape_options_are_one_line_errors(options, match):
    with pytest.raises(InputError, match=match):
        BayesConfig(**options)


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--size-range", "0.1,0.05"], "error: --size-range: got 0.1,0.05, expected 0 < MIN < MAX"),
        (["--size-range", "-0.01,0.05"], "error: --size-range: got -0.01,0.05"),
        (["--up", "0,0,0"], "error: --up: got [0.0, 0.0, 0.0], expected a vector of non-zero length"),
        (["--shape", "cube"], "error: --shape: got 'cube', expected one of"),
    ],
)
def test_cli_shape_options_exit_2_with_one_line(tmp_path, args, expected):
    path = tmp_path / "s.json"
    path.write_text(json.dumps(_session([Ellipsoid.sphere([0.6, 0.0, 0.5], 0.03)]).to_dict()))
    res = CliRunner().invoke(app, ["localize", str(path), "-q", *args])
    assert res.exit_code == 2
    assert res.stderr.startswith(expected) and res.stderr.count("\n") == 1


def test_cli_shape_outputs_in_the_result_json(tmp_path):
    path = tmp_path / "s.json"
    path.write_text(json.dumps(_session([Ellipsoid.spheroid([0.6, 0.0, 0.5], 0.02, 0.06)]).to_dict()))
    res = CliRunner().invoke(app, ["localize", str(path), "-q", "--shape", "spheroid", "--up", "0,0,1"])
    assert res.exit_code == 0, res.output
    (o,) = json.loads(res.stdout)["objects"]
    assert o["shape"] == "spheroid" and len(o["semi_axes"]) == 3 and len(o["quaternion_xyzw"]) == 4 and o["volume_m3"] > 0


def test_a_box_larger_than_its_sphere_sticks_out_and_a_cut_one_does_not():
    """No occluder makes a box larger: a sphere estimate smaller than the object leaves edges outside its predicted
    boxes (sticks_out), one larger than it leaves them inside (possibly_cut, not sticks_out)."""
    true = Ellipsoid.sphere([0.6, 0.0, 0.5], 0.03)
    problem, small = _object_at(true, 0.018)  # about 4 edge sigmas outside
    _, large = _object_at(true, 0.06)  # about 4 inside
    assert sticks_out(problem, small) and not possibly_cut(problem, small)
    assert possibly_cut(problem, large) and not sticks_out(problem, large)
    _, exact = _object_at(true, 0.03)
    assert not sticks_out(problem, exact) and not possibly_cut(problem, exact)


def test_a_lying_object_broadside_in_one_view_only_takes_its_shape():
    """Shipped table-top session (simulated, seed 800 of ``experiments/tabletop_subsets.py``, views 0, 4, 5): one lying
    240 x 110 x 120 mm ellipsoid is wide in one view and near-square in the two others; its wide box sticks out of the
    sphere the search found by 6.7 edge sigmas, which no cut does. Kept as that sphere it was 57 mm off; fitted, under
    4 mm (the others unchanged)."""
    from pathlib import Path

    from monovisual3d.truth import load_objects

    data = Path(__file__).parent / "data"
    truth = load_objects(data / "one_broadside_view.truth.json")
    est = mv.localize(mv.load_session(data / "one_broadside_view.session.json"), size_range=(0.02, 0.15)).positions
    d = np.linalg.norm(est[:, None] - truth.positions[None], axis=2)
    assert len(est) == 6 and sorted(d.argmin(axis=1)) == list(range(6))
    assert d[:, 5].min() < 0.01, d[:, 5].min()


@pytest.mark.parametrize(
    ("yaw", "views_deg"),
    [(0.0, ((-40, 60), (0, 60), (40, 20))), (0.3, ((-40, 60), (0, 60), (40, 20))), (0.3, ((-30, 60), (10, 60), (60, 20)))],
)
def test_a_flat_tray_seen_from_above_twice_and_from_the_side_once_is_found(yaw, views_deg):
    """A 200 x 160 x 30 mm tray, 0.6 m away, from two views 60 degrees above (its boxes near square) and one 20 degrees
    above (wide: log aspect 0.6-0.9 below its sphere's, far beyond box noise, :func:`strongly_elongated`). Kept as the
    search's sphere, the wide box taken as cut top and bottom, it came out 19-65 mm off; the lying fits find it."""
    from monovisual3d.frames import look_at
    from monovisual3d.geometry.solids import cuboid_bbox

    cam = mv.Camera.from_hfov(1280, 720, 69.0)
    centre = np.array([0.6, 0.0, 0.3])
    poses = []
    for az, el in np.radians(views_deg):
        poses.append(look_at(centre + 0.6 * np.array([-np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)]), centre))
    boxes = cuboid_bbox(cam, np.array(poses), centre, [0.10, 0.08, 0.015], rotation_upright(yaw))
    session = Session(cam, tuple(View(T, (Detection(b),)) for T, b in zip(poses, boxes)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = mv.localize(session, size_range=(0.02, 0.15), reach=1.0)
    assert len(result.objects) == 1
    assert result.objects[0].shape != "sphere"
    assert np.linalg.norm(result.positions[0] - centre) < 0.012


def test_the_skipped_ellipsoid_fit_could_not_have_changed_the_answer(monkeypatch):
    """Where the shape stage skips the lying ellipsoid's fit of a cut fruit (its best possible score cannot pay for its
    parameters), the full fit of every model keeps the answer too: on a dense row, every skip checked."""
    from monovisual3d.bench.scale import OPTIONS, row_session
    from monovisual3d.methods.bayes import shapes
    from monovisual3d.methods.bayes.fits import beats, lowest_bic_fit

    skipped, asked = [], []
    bound = shapes._ellipsoid_cannot_change

    def checked(problem, obj, answer, models, censored, hidden_to):
        out = bound(problem, obj, answer, models, censored, hidden_to)
        asked.append(out)
        if out:
            new = lowest_bic_fit(problem, obj, models, censored, hidden_to=hidden_to)
            skipped.append(new is None or (not new[0][0].solid and not beats(problem, obj, new[0], answer, new[1], hidden_to)))
        return out

    monkeypatch.setattr(shapes, "_ellipsoid_cannot_change", checked)
    mv.localize(row_session(96, 5, 0)[0], **OPTIONS)
    assert skipped and all(skipped), (asked, skipped)
    # a lying object, which the ellipsoid fits and the sphere does not: never skipped
    from monovisual3d.methods.bayes.fits import lying_shapes, sphere_answer

    problem, lying = _object_at(Ellipsoid.from_rotation([0.6, 0.0, 0.5], LYING, rotation_upright(0.5)), 0.035)
    assert not bound(problem, lying, sphere_answer(lying), lying_shapes(3), None, None)
    assert shapes.fit_shape(problem, lying).shape == "ellipsoid"
