"""Session-level input checks: each mistake of sim/mistakes is named, a clean session gets no cause."""

from __future__ import annotations

import dataclasses
import functools
import warnings

import numpy as np
import pytest

from monovisual3d.bench.trust_cases import make_case
from monovisual3d.camera import Camera
from monovisual3d.errors import InputError
from monovisual3d.session import Session
from monovisual3d.session.diagnose import (
    box_stretch,
    check_session,
    distortion_causes,
    duplicate_views,
    pose_hypothesis,
    views_as_given,
)
from monovisual3d.session.load import session_from_dict
from monovisual3d.session.rays import ray_agreement
from monovisual3d.sim import mistakes
from monovisual3d.verdict import Cause

FAMILIES = ("paper", "greenhouse", "arc", "row")
pytestmark = pytest.mark.filterwarnings("ignore::monovisual3d.errors.InputWarning")  # the loader's clipped boxes


@functools.cache
def _case(family: str, seed: int, sigma: float):  # type: ignore[no-untyped-def]
    return make_case(family, seed, sigma)


@pytest.fixture(scope="module", params=FAMILIES)
def case(request: pytest.FixtureRequest):  # type: ignore[no-untyped-def]
    return _case(request.param, 0, 0.05)


def _causes(session_dict: dict) -> list[Cause]:
    """The causes of a session as written (the loader's clipping warnings silenced)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return check_session(session_from_dict(session_dict))[1]


def test_a_clean_session_has_no_cause(case) -> None:  # type: ignore[no-untyped-def]
    assert _causes(case.session.to_dict()) == []


@pytest.mark.parametrize(("family", "sigma"), [("greenhouse", 0.02), ("arc", 0.10)])
def test_clean_sessions_have_no_cause_at_other_noise(family: str, sigma: float) -> None:
    assert _causes(_case(family, 1, sigma).session.to_dict()) == []


@pytest.mark.parametrize(
    ("mistake", "cause", "word"),
    [
        ("views-twice", "duplicate_views", "duplicate"),
        ("one-pose", "one_pose", "same pose"),
        ("poses-inverted", "pose_convention", "inverted"),
        ("camera-link-as-optical", "pose_convention", "camera_link"),
        ("optical-as-camera-link", "pose_convention", "camera_link"),
        ("image-size-smaller", "image_size", "image"),
    ],
)
def test_each_mistake_is_named(case, mistake: str, cause: str, word: str) -> None:  # type: ignore[no-untyped-def]
    bad = mistakes.make_mistake(mistake, case.inputs(), rng=0).session
    found = _causes(bad)
    assert cause in {c.cause for c in found}
    assert any(word in c.message for c in found if c.cause == cause)


def test_the_right_convention_wins_the_ray_test(case) -> None:  # type: ignore[no-untyped-def]
    s = case.session
    T = np.stack([v.T_base_optical for v in s.views])
    boxes = [v.boxes_xyxy for v in s.views]
    given = ray_agreement(s.camera, T, boxes)
    assert given is not None and given > 0.8
    for name in ("inverted", "camera_link_as_optical", "optical_as_camera_link"):
        other = ray_agreement(s.camera, pose_hypothesis(T, name), boxes)
        assert other is not None and other < given - 0.3, name


def test_pose_hypotheses_undo_the_mistakes() -> None:
    s = _case("paper", 0, 0.05).session
    T = np.stack([v.T_base_optical for v in s.views])
    inverted = session_from_dict(mistakes.inverted_poses(s.to_dict()))
    T_bad = np.stack([v.T_base_optical for v in inverted.views])
    np.testing.assert_allclose(pose_hypothesis(T_bad, "inverted"), T, atol=1e-9)
    link = session_from_dict(mistakes.camera_link_as_optical(s.to_dict()))
    T_bad = np.stack([v.T_base_optical for v in link.views])
    np.testing.assert_allclose(pose_hypothesis(T_bad, "camera_link_as_optical"), T, atol=1e-9)
    declared = session_from_dict(mistakes.optical_as_camera_link(s.to_dict()))
    T_bad = np.stack([v.T_base_optical for v in declared.views])
    np.testing.assert_allclose(pose_hypothesis(T_bad, "optical_as_camera_link"), T, atol=1e-9)
    np.testing.assert_allclose(pose_hypothesis(pose_hypothesis(T, "facing_away"), "facing_away"), T, atol=1e-12)
    with pytest.raises(ValueError, match="expected 'given' or one of"):
        pose_hypothesis(T, "upside_down")


def test_normalised_boxes_are_refused_with_the_scale() -> None:
    s = _case("paper", 0, 0.05).session.to_dict()
    with pytest.raises(InputError, match="normalised to 0..1.*multiply x by 640 and y by 480"):
        session_from_dict(mistakes.normalised_boxes(s))


def test_xywh_boxes_are_refused_naming_the_order() -> None:
    s = _case("arc", 0, 0.05).session.to_dict()
    with pytest.raises(InputError, match=r"x2 <= x1.*x,y,w,h"):
        session_from_dict(mistakes.xywh_boxes(s))


def test_swapped_boxes_are_named_refused_or_not() -> None:
    wide = _case("arc", 0, 0.05).session.to_dict()  # y up to 960 in a 540-high image: refused
    with pytest.raises(InputError, match="y1, x1, y2, x2"):
        session_from_dict(mistakes.yxyx_boxes(wide))
    near_square = _case("greenhouse", 1, 0.05).session.to_dict()  # every swapped box inside 640x480: the ray test
    found = _causes(mistakes.yxyx_boxes(near_square))
    assert [c.cause for c in found] == ["box_coordinates"]
    assert "swapped" in found[0].message


def test_boxes_past_the_image_name_the_image_size() -> None:
    s = _case("paper", 0, 0.05).session.to_dict()
    bad = mistakes.boxes_from_resized_images(s, (800, 600))  # 1.25x: past the right and bottom, none wholly outside
    found = _causes(bad)
    assert "image_size" in {c.cause for c in found}
    assert any("larger image" in c.message for c in found)


def test_a_square_detector_input_is_named_by_the_box_aspect() -> None:
    s = _case("greenhouse", 1, 0.05).session.to_dict()  # stays inside the image: only the aspect tells
    found = _causes(mistakes.boxes_from_resized_images(s, (640, 640)))
    assert [c.cause for c in found] == ["image_size"]
    assert "640x640 square" in found[0].message


def test_duplicates_are_dropped_and_associations_map_back() -> None:
    s = _case("paper", 0, 0.05).session
    twice = Session(s.camera, s.views + s.views[:1])
    checked, causes = duplicate_views(twice)
    assert len(checked.views) == len(s.views)
    assert causes[0].views == (len(s.views),)
    assert views_as_given({0: 4, 2: 1}, causes) == {0: 4, 2: 1, len(s.views): 4}
    assert duplicate_views(s) == (s, [])


@pytest.mark.parametrize(
    ("coefficients", "words"),
    [
        ((-0.2, 0.07, 0.03, -0.001, 0.001), "k1, k2, k3, p1, p2"),  # k3 in the p1 slot
        ((0.2, -0.07, 0.001, -0.001, -0.03), "flipped signs"),
    ],
)
def test_distortion_patterns_no_lens_has(coefficients: tuple[float, ...], words: str) -> None:
    cam = Camera(960, 540, 625.0, 625.0, 480.0, 270.0, "plumb_bob", coefficients)
    (cause,) = distortion_causes(cam)
    assert cause.cause == "distortion" and words in cause.message


def test_a_real_lens_passes_the_distortion_test() -> None:
    assert distortion_causes(Camera(960, 540, 625.0, 625.0, 480.0, 270.0, "plumb_bob", (-0.25, 0.08, 0.001, -0.0015, 0.02))) == []
    assert distortion_causes(Camera.from_hfov(640, 480, 69.0)) == []


def test_import_warns_of_boxes_from_a_smaller_image() -> None:
    from monovisual3d.io.build import assemble_session
    from monovisual3d.io.detections import ImageDetections
    from monovisual3d.session import Detection

    s = _case("row", 0, 0.05).session
    scale = np.array([2 / 3, 2 / 3, 2 / 3, 2 / 3])  # boxes of 640x360 images under the 960x540 calibration
    pairs = [
        (v.T_base_optical, ImageDetections(f"{i}.png", detections=tuple(Detection(d.bbox_xyxy * scale) for d in v.detections)))
        for i, v in enumerate(s.views)
    ]
    with pytest.warns(UserWarning, match="smaller image"):
        assemble_session(s.camera, pairs)


def test_a_centre_crop_of_a_4_3_sensor_is_named() -> None:
    s = _case("paper", 0, 0.05).session.to_dict()
    found = _causes(mistakes.boxes_from_centre_crop(s, (640, 360)))
    assert [c.cause for c in found] == ["image_size"]
    assert "crop" in found[0].message


def test_cameras_facing_away_are_named(case) -> None:  # type: ignore[no-untyped-def]
    s = case.session
    away = Session(
        s.camera,
        tuple(dataclasses.replace(v, T_base_optical=pose_hypothesis(v.T_base_optical[None], "facing_away")[0]) for v in s.views),
    )
    (cause,) = check_session(away)[1]
    assert cause.cause == "pose_convention" and "facing away" in cause.message


def test_localize_counts_duplicates_once_and_says_so() -> None:
    import monovisual3d as mv

    s = _case("paper", 0, 0.05).session
    clean = mv.localize(s)
    assert clean.quality.get("verdict", "ok") == "ok" and not any("duplicate" in w for w in clean.warnings)
    twice = Session(s.camera, s.views + s.views)
    with pytest.warns(UserWarning, match="duplicate views"):
        r = mv.localize(twice)
    np.testing.assert_allclose(r.positions, clean.positions, atol=1e-9)  # the same answer: each view counted once
    assert r.quality["verdict"] == "suspect"
    assert [c["cause"] for c in r.quality["causes"]][:1] == ["duplicate_views"]
    assert "duplicate" in r.warnings[0]
    n = len(s.views)
    for obj, ref in zip(r.objects, clean.objects):
        assert obj.associations == {**ref.associations, **{v + n: d for v, d in ref.associations.items()}}


def test_tall_boxes_around_the_principal_point_are_tall_objects_not_a_stretch() -> None:
    """Containers 1.8 times as tall as wide, centred in a 1280x720 image, have the aspect of boxes stretched to a square
    detector input; stretched boxes also sit 1.78 times as far down the image, which those do not."""
    rng = np.random.default_rng(0)
    W, H, cx, cy = 1280, 720, 640.0, 360.0
    xc, yc = rng.uniform(400.0, 880.0, 12), rng.uniform(250.0, 470.0, 12)
    w = rng.uniform(40.0, 80.0, 12)
    tall = np.stack([xc - w / 2, yc - 0.9 * w, xc + w / 2, yc + 0.9 * w], axis=1)
    assert box_stretch(tall, W, H, cx, cy) is None
    round_boxes = np.stack([xc - w / 2, yc - w / 2, xc + w / 2, yc + w / 2], axis=1)
    stretched = round_boxes * np.array([1.0, W / H, 1.0, W / H])  # a 1280x1280 input's boxes, not scaled back
    assert box_stretch(stretched, W, H, cx, cy) == pytest.approx(W / H)
    assert box_stretch(tall, W, H) == pytest.approx(1.8)  # without the principal point: the aspect alone
