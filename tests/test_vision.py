"""Vision: box helpers (numpy) and the colour detector (OpenCV) on synthetic images.

The comparison of the detector with rendered segmentation lives in tests/sim/test_mujoco.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d import InputError
from monovisual3d.vision import box_iou, boxes_from_label_image, match_boxes

# ---------------------------------------------------------------------- boxes (numpy only)


def test_boxes_from_label_image_edge_convention() -> None:
    labels = np.full((30, 40), -1, dtype=np.int32)
    labels[5:12, 10:20] = 0  # rows 5..11, columns 10..19
    labels[20, 39] = 2  # one pixel in the bottom-right corner region
    boxes, pixels = boxes_from_label_image(labels, 3)
    assert boxes.shape == (3, 4) and pixels.shape == (3,)
    assert_array_equal(boxes[0], [10, 5, 20, 12])
    assert np.all(np.isnan(boxes[1])) and pixels[1] == 0
    assert_array_equal(boxes[2], [39, 20, 40, 21])
    assert_array_equal(pixels, [70, 0, 1])


def test_boxes_from_label_image_min_pixels_and_out_of_range_labels() -> None:
    labels = np.zeros((4, 4), dtype=np.int64)
    labels[0, 0] = 1
    labels[3, 3] = 7  # beyond count: background
    boxes, pixels = boxes_from_label_image(labels, 2, min_pixels=2)
    assert np.all(np.isnan(boxes[1])) and pixels[1] == 1
    assert_array_equal(boxes[0], [0, 0, 4, 4])


def test_boxes_from_label_image_matches_brute_force(rng: np.random.Generator) -> None:
    labels = rng.integers(-1, 5, size=(23, 31))
    labels[labels == 3] = -1  # label 3 absent
    boxes, pixels = boxes_from_label_image(labels, 5)
    for k in range(5):
        v, u = np.nonzero(labels == k)
        if k == 3:
            assert np.all(np.isnan(boxes[k]))
            continue
        assert_array_equal(boxes[k], [u.min(), v.min(), u.max() + 1, v.max() + 1])
        assert pixels[k] == len(u)


@pytest.mark.parametrize(
    ("labels", "count", "match"),
    [
        (np.zeros((2, 2, 2), int), 1, "height, width"),
        (np.zeros((2, 2)), 1, "integer labels"),
        (np.zeros((2, 2), int), -1, "non-negative integer"),
    ],
)
def test_boxes_from_label_image_rejects_bad_input(labels: np.ndarray, count: int, match: str) -> None:
    with pytest.raises(InputError, match=match):
        boxes_from_label_image(labels, count)


def test_box_iou_reference_values_and_identities(rng: np.random.Generator) -> None:
    assert_allclose(box_iou([0, 0, 2, 2], [1, 0, 3, 2]), 1 / 3)
    assert_allclose(box_iou([0, 0, 1, 1], [2, 2, 3, 3]), 0.0)
    xy = rng.uniform(0, 100, (50, 2))
    wh = rng.uniform(1, 30, (50, 2))
    a = np.concatenate([xy, xy + wh], axis=1)
    b = a + rng.normal(0, 3, a.shape)
    b[:, 2:] = np.maximum(b[:, 2:], b[:, :2] + 0.5)
    assert_allclose(box_iou(a, a), 1.0)
    assert_allclose(box_iou(a, b), box_iou(b, a))
    assert box_iou(a[:, None], b[None]).shape == (50, 50)
    assert np.all((box_iou(a, b) >= 0) & (box_iou(a, b) <= 1))
    assert np.isnan(box_iou([np.nan] * 4, [0, 0, 1, 1]))
    with pytest.raises(InputError, match=r"\(\.\.\., 4\)"):
        box_iou([0, 0, 1], [0, 0, 1, 1])


def test_match_boxes_pairs_by_overlap() -> None:
    a = np.array([[0, 0, 10, 10], [50, 50, 60, 60], [np.nan] * 4])
    b = np.array([[51, 50, 61, 60], [200, 200, 210, 210], [1, 0, 11, 10]])
    ia, ib, iou = match_boxes(a, b)
    assert_array_equal(ia, [0, 1])
    assert_array_equal(ib, [2, 0])
    assert np.all(iou > 0.8)
    ia, ib, iou = match_boxes(np.zeros((0, 4)), b)
    assert ia.shape == ib.shape == iou.shape == (0,)


# ---------------------------------------------------------------------- colour detector (OpenCV)

cv2 = pytest.importorskip("cv2")

from monovisual3d.vision import (  # noqa: E402  (after the importorskip on purpose)
    ColourDetectorConfig,
    colour_mask_from_rgb,
    detect_colour,
    detections_from_mask,
    fill_holes,
)

RED = (205, 30, 25)
GREEN = (40, 150, 45)


def synthetic_image(
    rng: np.random.Generator, discs: list[tuple[int, int, int]], size: tuple[int, int] = (320, 240)
) -> np.ndarray:
    """Grey-green noisy background with red discs (centre u, centre v, radius), RGB uint8."""
    w, h = size
    img = np.clip(rng.normal(95, 12, (h, w, 3)), 0, 255).astype(np.uint8)
    img[..., 1] = np.clip(img[..., 1].astype(int) + 15, 0, 255)
    cv2.rectangle(img, (5, 5), (60, 40), GREEN, -1)  # a leaf
    for u, v, r in discs:
        cv2.circle(img, (u, v), r, RED, -1)
        cv2.circle(img, (u - r // 3, v - r // 3), max(r // 5, 1), (255, 245, 240), -1)  # specular highlight
    return img


def disc_box(u: int, v: int, r: int) -> np.ndarray:
    """Box of cv2.circle(img, (u, v), r, filled): pixels u - r .. u + r."""
    return np.array([u - r, v - r, u + r + 1, v + r + 1], dtype=float)


def test_detect_colour_finds_discs_with_exact_boxes(rng: np.random.Generator) -> None:
    discs = [(80, 120, 25), (200, 90, 15), (260, 180, 8)]
    dets = detect_colour(synthetic_image(rng, discs))
    assert len(dets) == 3
    boxes = np.stack([d.bbox_xyxy for d in dets])
    truth = np.stack([disc_box(*d) for d in discs])
    ia, ib, iou = match_boxes(truth, boxes)
    assert len(ia) == 3
    assert_allclose(boxes[ib], truth[ia], atol=0.0)
    scores = np.array([d.score for d in dets])
    assert np.all((scores > 0.5) & (scores <= 1.0))
    assert all(d.label == "fruit" for d in dets)
    assert list(scores) == sorted(scores, reverse=True)


def test_detect_colour_ignores_other_colours_and_small_blobs(rng: np.random.Generator) -> None:
    img = synthetic_image(rng, [])
    img[100:103, 100:103] = RED  # 9 px, below min_area_px
    cv2.circle(img, (200, 150), 20, (30, 40, 200), -1)  # blue
    cv2.circle(img, (100, 180), 20, (200, 190, 30), -1)  # yellow
    assert detect_colour(img) == []
    assert len(detect_colour(img, ColourDetectorConfig(min_area_px=5, open_px=0))) == 1


def test_detect_colour_box_is_clipped_at_the_border(rng: np.random.Generator) -> None:
    img = synthetic_image(rng, [(310, 230, 20)])
    (det,) = detect_colour(img)
    assert_allclose(det.bbox_xyxy, [290, 210, 320, 240])


def test_colour_mask_hue_wraps_around_zero() -> None:
    img = np.zeros((10, 20, 3), np.uint8)
    img[:, :10] = (200, 10, 40)  # hue about 348 degrees
    img[:, 10:] = (200, 40, 10)  # hue about 9 degrees
    mask = colour_mask_from_rgb(img, ColourDetectorConfig(open_px=0, close_px=0))
    assert mask.all()
    only_low = ColourDetectorConfig(hue_ranges_deg=((0.0, 20.0),), open_px=0, close_px=0)
    assert_array_equal(colour_mask_from_rgb(img, only_low)[0], [False] * 10 + [True] * 10)


def test_fill_holes_keeps_border_background() -> None:
    m = np.zeros((9, 9), bool)
    m[2:7, 2:7] = True
    m[4, 4] = False  # hole
    m[0, 0] = False
    filled = fill_holes(m)
    assert filled[4, 4] and not filled[0, 0] and filled.sum() == 25


def test_detections_from_mask_score_disc_vs_ragged() -> None:
    m = np.zeros((100, 100), np.uint8)
    cv2.circle(m, (30, 30), 20, 1, -1)
    m[70:72, 10:90] = 1  # thin bar: fill 1, but score capped at 1
    m[80, 10:60:2] = 1  # dotted line: one component per dot, all below min area
    dets = detections_from_mask(m.astype(bool))
    assert len(dets) == 2
    disc = next(d for d in dets if d.bbox_xyxy[0] == 10 and d.bbox_xyxy[1] == 10)
    assert_allclose(disc.bbox_xyxy, [10, 10, 51, 51])
    assert disc.score > 0.9


@pytest.mark.parametrize(
    ("image", "match"),
    [
        (np.zeros((10, 10), np.uint8), r"\(height, width, 3\)"),
        (np.zeros((10, 10, 3), np.float32), "uint8"),
    ],
)
def test_detect_colour_rejects_bad_images(image: np.ndarray, match: str) -> None:
    with pytest.raises(InputError, match=match):
        detect_colour(image)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"hue_ranges_deg": ()}, "at least one"),
        ({"hue_ranges_deg": ((20.0, 10.0),)}, "low <= high"),
        ({"saturation_min": 1.5}, "fraction"),
        ({"min_area_px": -1}, "non-negative integer"),
        ({"open_px": 2.5}, "non-negative integer"),
    ],
)
def test_config_rejects_bad_values(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        ColourDetectorConfig(**kwargs)
