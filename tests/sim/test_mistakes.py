"""Integration mistakes: each changes what it should and nothing else, reproducibly, in the right frames."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.spatial.transform import Rotation

from monovisual3d import load_session
from monovisual3d.camera import Camera
from monovisual3d.errors import InputError
from monovisual3d.frames import T_base_optical_from_T_base_cameralink
from monovisual3d.sim import mistakes as mk
from monovisual3d.sim.motion import frame_times
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import paper_scene, scene_target
from monovisual3d.sim.simulate import simulate
from monovisual3d.sim.viewpoints import arc_poses

N_VIEWS = 4
RATE = 5.0
CAMERA = Camera(640, 480, 460.0, 460.0, 320.0, 240.0, "plumb_bob", (-0.2, 0.05, 0.001, -0.001, 0.01))


def _arc(at):
    return arc_poses(scene_target(paper_scene()), N_VIEWS, span=math.radians(60.0), at=at)


@pytest.fixture(scope="module")
def inputs() -> mk.MistakeInputs:
    frames = frame_times(_arc, N_VIEWS, RATE)
    session, _ = simulate(paper_scene(), CAMERA, _arc(np.arange(N_VIEWS)), noise=NoiseModel(box_sigma=0.03), rng=0, frames=frames)
    return mk.MistakeInputs(session.to_dict(), frames)


def _parts(session: dict) -> dict:
    """The parts of a session a mistake may change, each comparable with ==."""
    return {
        "camera": json.dumps(session["camera"], sort_keys=True),
        "pose_frame": session.get("pose_frame"),
        "n_views": len(session["views"]),
        "poses": json.dumps([v["pose"] for v in session["views"]]),
        "boxes": json.dumps([v["detections"] for v in session["views"]]),
    }


#: What each mistake class may change; every other part must stay as it was.
CHANGES = {
    "image-size-smaller": {"boxes"},
    "image-size-larger": {"boxes"},
    "detector-input-size": {"boxes"},
    "centre-crop": {"boxes"},
    "boxes-normalised": {"boxes"},
    "boxes-yxyx": {"boxes"},
    "boxes-xywh": {"boxes"},
    "hand-eye-2deg": {"poses"},
    "hand-eye-1cm": {"poses"},
    "hand-eye-2deg-1cm": {"poses"},
    "poses-frame-late": {"poses"},
    "poses-frame-early": {"poses"},
    "poses-half-frame-late": {"poses"},
    "boxes-of-other-view": {"boxes"},
    "swapped-boxes": {"boxes"},
    "pose-of-other-view": {"poses"},
    "swapped-poses": {"poses"},
    "views-twice": {"n_views", "poses", "boxes"},
    "poses-inverted": {"poses"},
    "camera-link-as-optical": {"poses"},
    "optical-as-camera-link": {"pose_frame"},
    "distortion-order": {"camera"},
    "distortion-signs": {"camera"},
    "one-pose": {"poses"},
}


def test_every_mistake_is_listed_with_what_it_changes():
    assert set(CHANGES) == set(mk.MISTAKES)


@pytest.mark.parametrize("name", sorted(mk.MISTAKES))
def test_each_mistake_changes_what_it_should_and_nothing_else(inputs, name):
    before = copy.deepcopy(inputs.session)
    made = mk.make_mistake(name, inputs, rng=7)
    assert inputs.session == before  # the input is never changed
    old, new = _parts(inputs.session), _parts(made.session)
    changed = {k for k in old if old[k] != new[k]}
    assert changed == CHANGES[name], (name, changed)
    assert made.words and all(isinstance(w, str) and w for w in made.words)
    again = mk.make_mistake(name, inputs, rng=7)
    assert again.session == made.session and again.details == made.details  # seeded
    json.dumps(made.details)  # plain JSON values


def test_drawn_mistakes_differ_between_seeds(inputs):
    a = mk.make_mistake("hand-eye-2deg", inputs, rng=1).details["E_hand_eye"]
    b = mk.make_mistake("hand-eye-2deg", inputs, rng=2).details["E_hand_eye"]
    assert not np.allclose(a, b)
    views = {mk.make_mistake("boxes-of-other-view", inputs, rng=s).details["view"] for s in range(20)}
    assert views == set(range(N_VIEWS))


def test_resized_and_cropped_boxes(inputs):
    s = inputs.session
    boxes = [np.array(d["bbox_xyxy"]) for v in s["views"] for d in v["detections"]]
    small = mk.boxes_from_resized_images(s, (320, 240))
    assert_allclose([d["bbox_xyxy"] for v in small["views"] for d in v["detections"]], np.array(boxes) / 2)
    crop = mk.boxes_from_centre_crop(s, (640, 360))
    for v0, v1 in zip(s["views"], crop["views"]):
        assert len(v1["detections"]) <= len(v0["detections"])
        for d in v1["detections"]:
            x1, y1, x2, y2 = d["bbox_xyxy"]
            assert 0 <= x1 < x2 <= 640 and 0 <= y1 < y2 <= 360
    shifted = mk.boxes_from_centre_crop(s, (640, 480))  # the whole image: nothing moves
    assert shifted == s
    assert mk.other_aspect_crop((640, 480)) == (640, 360) and mk.other_aspect_crop((1920, 1080)) == (1440, 1080)
    with pytest.raises(InputError, match="crop_size: got .* within the 640x480 image"):
        mk.boxes_from_centre_crop(s, (700, 400))


def test_box_coordinate_mistakes(inputs):
    s = inputs.session
    box = np.array(s["views"][0]["detections"][0]["bbox_xyxy"])
    assert_allclose(mk.normalised_boxes(s)["views"][0]["detections"][0]["bbox_xyxy"], box / [640, 480, 640, 480])
    assert_allclose(mk.yxyx_boxes(s)["views"][0]["detections"][0]["bbox_xyxy"], box[[1, 0, 3, 2]])
    x, y, w, h = mk.xywh_boxes(s)["views"][0]["detections"][0]["bbox_xyxy"]
    assert_allclose([x, y, x + w, y + h], box)
    with pytest.raises(InputError, match=r"x2 <= x1 or y2 <= y1"):  # a small box far from the corner: refused on load
        load_session(mk.xywh_boxes(s))


def test_hand_eye_error_is_one_camera_frame_motion_in_every_view(inputs):
    E = mk.hand_eye_offset(2.0, 10.0, rng=3)
    assert_allclose(np.degrees(Rotation.from_matrix(E[:3, :3]).magnitude()), 2.0)
    assert_allclose(np.linalg.norm(E[:3, 3]), 0.010)
    bad = mk.hand_eye_error(inputs.session, E)
    assert_allclose(mk.poses_of(bad), mk.poses_of(inputs.session) @ E, atol=1e-12)


def test_poses_a_frame_late_are_the_next_views_and_extrapolate_along_the_path(inputs):
    T = mk.poses_of(inputs.session)
    late = mk.poses_of(mk.poses_shifted_by_frames(inputs.session, 1))
    assert_allclose(late[:-1], T[1:], atol=1e-9)
    assert_allclose(late[-1], _arc(np.array([float(N_VIEWS)]))[0], atol=1e-9)  # constant motion beyond the last view
    early = mk.poses_of(mk.poses_shifted_by_frames(inputs.session, -1))
    assert_allclose(early[0], _arc(np.array([-1.0]))[0], atol=1e-9)
    streamed = mk.poses_of(mk.poses_at_time_offset(inputs.session, inputs.frames, 1.0 / RATE))
    assert_allclose(streamed, late, atol=1e-5)  # interpolated in the 100 Hz stream
    with pytest.raises(InputError, match="has no pose in the stream"):
        mk.poses_at_time_offset(inputs.session, inputs.frames, 5.0)


def test_pose_convention_mistakes_are_the_frames_they_stand_for(inputs):
    T = mk.poses_of(inputs.session)
    inv = mk.poses_of(mk.inverted_poses(inputs.session))
    assert_allclose(inv @ T, np.broadcast_to(np.eye(4), T.shape), atol=1e-9)
    link = mk.poses_of(mk.camera_link_as_optical(inputs.session))
    assert_allclose(T_base_optical_from_T_base_cameralink(link), T, atol=1e-9)  # the camera_link pose of the camera
    declared = mk.optical_as_camera_link(inputs.session)
    assert declared["pose_frame"] == "camera_link"
    loaded = load_session(declared)  # read as camera_link: every optical axis turned
    assert not np.allclose(loaded.views[0].T_base_optical, T[0])


def test_view_mistakes_touch_the_named_views_only(inputs):
    s = inputs.session
    bad = mk.boxes_from_other_view(s, 1, 3)
    assert bad["views"][1]["detections"] == s["views"][3]["detections"]
    assert [bad["views"][i] for i in (0, 2, 3)] == [s["views"][i] for i in (0, 2, 3)]
    bad = mk.swapped_boxes(s, 0, 2)
    assert bad["views"][0]["detections"] == s["views"][2]["detections"]
    assert bad["views"][2]["detections"] == s["views"][0]["detections"] and bad["views"][1] == s["views"][1]
    bad = mk.pose_of_other_view(s, 0, 2)
    assert bad["views"][0]["pose"] == s["views"][2]["pose"] and bad["views"][1:] == s["views"][1:]
    bad = mk.swapped_poses(s, 0, 3)
    assert bad["views"][0]["pose"] == s["views"][3]["pose"] and bad["views"][3]["pose"] == s["views"][0]["pose"]
    twice = mk.views_twice(s)
    assert twice["views"] == s["views"] + s["views"]
    one = mk.poses_of(mk.all_views_one_pose(s, 2))
    assert_allclose(one, np.repeat(mk.poses_of(s)[2:3], N_VIEWS, axis=0), atol=1e-12)
    with pytest.raises(InputError, match="view: got 9, expected a view index in 0..3"):
        mk.boxes_from_other_view(s, 9, 0)


def test_view_mistakes_name_the_wrong_view(inputs):
    made = mk.make_mistake("pose-of-other-view", inputs, rng=5)
    assert made.words == (f"views[{made.details['view']}]",)
    assert made.details["view"] != made.details["other"]
    swapped = mk.make_mistake("swapped-poses", inputs, rng=5)
    assert set(swapped.words) == {f"views[{swapped.details['view']}]", f"views[{swapped.details['other']}]"}


def test_distortion_mistakes(inputs):
    k1, k2, p1, p2, k3 = CAMERA.distortion_coefficients
    order = mk.distortion_wrong_order(inputs.session)["camera"]["distortion"]["coefficients"]
    assert order == [k1, k2, k3, p1, p2]
    signs = mk.distortion_flipped_signs(inputs.session)["camera"]["distortion"]["coefficients"]
    assert_allclose(signs, [-k1, -k2, -p1, -p2, -k3])
    ideal, _ = simulate(paper_scene(), rng=0)
    with pytest.raises(InputError, match="plumb_bob model with 5 coefficients"):
        mk.distortion_wrong_order(ideal.to_dict())


def test_the_registry_says_what_each_mistake_needs(inputs):
    ideal, _ = simulate(paper_scene(), rng=0)
    bare = mk.MistakeInputs(ideal.to_dict())
    assert not mk.applies(mk.MISTAKES["poses-frame-late"], bare)
    assert not mk.applies(mk.MISTAKES["distortion-signs"], bare)
    assert mk.applies(mk.MISTAKES["hand-eye-2deg"], bare) and mk.applies(mk.MISTAKES["distortion-signs"], inputs)
    with pytest.raises(InputError, match="needs path"):
        mk.make_mistake("poses-half-frame-late", bare)
    with pytest.raises(InputError, match="mistake: got 'nope'"):
        mk.make_mistake("nope", bare)
    assert {m.cause for m in mk.MISTAKES.values()} >= {
        "image_size",
        "box_coordinates",
        "hand_eye",
        "time_offset",
        "view_disagrees",
        "duplicate_views",
        "pose_convention",
        "distortion",
    }
    assert_array_equal(sorted(mk.CAUSE_WORDS["image_size"]), ["crop", "image size", "resolution"])
