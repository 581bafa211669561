"""Detection readers (YOLO, COCO, CSV) on real-format fixtures, and the score/label filters."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.errors import InputError
from monovisual3d.io import (
    ImageDetections,
    ImportSummary,
    filter_detections,
    load_class_names,
    read_coco,
    read_detections,
    read_detections_csv,
    read_yolo_labels,
)
from monovisual3d.session import Detection

TOMATO_000 = [288.0, 210.0, 352.0, 270.0]  # the same tomato in every fixture format
LEAF_000 = [144.0, 129.0, 176.0, 159.0]


def by_image(frames: list[ImageDetections]) -> dict[str, ImageDetections]:
    return {f.image.split(".")[0]: f for f in frames}


def test_yolo_folder_with_classes_txt(fixtures):
    frames = by_image(read_detections(fixtures / "yolo_labels", image_size=(640, 480)))
    assert sorted(frames) == ["img_000", "img_001", "img_002"]
    f = frames["img_000"]
    assert [d.label for d in f.detections] == ["tomato", "leaf", "tomato"]
    assert [d.score for d in f.detections] == [0.91, 0.42, 0.66]
    assert_allclose(f.detections[0].bbox_xyxy, TOMATO_000)
    assert_allclose(f.detections[1].bbox_xyxy, LEAF_000)
    assert f.source.endswith("img_000.txt")


def test_yolo_segmentation_line_gives_polygon_mask(fixtures):
    f = by_image(read_yolo_labels(fixtures / "yolo_labels", (640, 480)))["img_002"]
    (d,) = f.detections
    assert d.score == 0.93
    poly = np.array(d.mask["polygon"])
    assert poly.shape == (7, 2)
    assert_allclose(d.bbox_xyxy, [poly[:, 0].min(), poly[:, 1].min(), poly[:, 0].max(), poly[:, 1].max()])
    assert_allclose(poly[0], [0.40 * 640, 0.50 * 480])


def test_yolo_class_names_from_data_yaml_and_no_confidence(tmp_path, fixtures):
    (tmp_path / "a.txt").write_text("1 0.5 0.5 0.2 0.2\n")
    (f,) = read_yolo_labels(tmp_path, (100, 50), class_names=fixtures / "yolo_data.yaml")
    (d,) = f.detections
    assert d.label == "leaf" and d.score is None
    assert_allclose(d.bbox_xyxy, [40, 20, 60, 30])
    (f,) = read_yolo_labels(tmp_path, (100, 50))
    assert f.detections[0].label == "1"


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("0 0.5 0.5 0.1", "4 values, expected 'class cx cy w h"),
        ("0 0.5 0.5 -0.1 0.1", "box width and height must be positive"),
        ("0 0.5 0.5 0.1 0.1 1.5", r"confidence 1.5, expected a value in \[0, 1\]"),
        ("x 0.5 0.5 0.1 0.1", "class: expected a number, got 'x'"),
        ("0 0.5 nan 0.1 0.1", "value 3: got nan, expected a finite number"),
        ("0 0.1 0.1 0.2 0.2 0.3 0.4 1.7", r"confidence 1.7, expected a value in \[0, 1\]"),
    ],
)
def test_yolo_bad_lines_name_file_and_line(tmp_path, line, message):
    (tmp_path / "img.txt").write_text("0 0.5 0.5 0.1 0.1\n" + line + "\n")
    with pytest.raises(InputError, match=rf"img.txt: line 2: {message}"):
        read_yolo_labels(tmp_path, (640, 480))


def test_yolo_needs_image_size_and_files(tmp_path, fixtures):
    with pytest.raises(InputError, match="YOLO boxes are normalised: the image size is needed"):
        read_detections(fixtures / "yolo_labels")
    with pytest.raises(InputError, match=r"no YOLO label files \(\*.txt\) in this folder"):
        read_yolo_labels(tmp_path, (640, 480))


def test_coco_results_with_images_file(fixtures):
    frames = by_image(read_detections(fixtures / "coco_results.json", images=fixtures / "coco_annotations.json"))
    assert sorted(frames) == ["img_000", "img_001", "img_002"]
    assert frames["img_002"].detections == ()
    assert frames["img_000"].image_size == (640, 480)
    assert [d.label for d in frames["img_000"].detections] == ["tomato", "leaf"]
    assert_allclose(frames["img_000"].detections[0].bbox_xyxy, TOMATO_000)
    assert_allclose(frames["img_000"].detections[1].bbox_xyxy, LEAF_000)
    assert frames["img_001"].detections[0].mask == {"polygon": [[357, 218], [385, 190], [413, 218], [385, 246]]}


def test_coco_annotation_file_and_errors(fixtures):
    data = json.loads((fixtures / "coco_annotations.json").read_text())
    data["annotations"] = [{"id": 7, "image_id": 3, "category_id": 1, "bbox": [10, 20, 30, 40], "area": 1200, "iscrowd": 0}]
    frames = by_image(read_coco(data))
    (d,) = frames["img_002"].detections
    assert d.score is None and d.label == "tomato"
    assert_allclose(d.bbox_xyxy, [10, 20, 40, 60])
    data["annotations"][0]["image_id"] = 9
    with pytest.raises(InputError, match=r"coco: annotations\[0\].image_id: 9 is not in the images list"):
        read_coco(data)
    results = json.loads((fixtures / "coco_results.json").read_text())
    with pytest.raises(InputError, match="numeric id 1 and no images list"):
        read_coco(results)
    results[0]["bbox"] = [1, 2, -3, 4]
    with pytest.raises(InputError, match=r"annotations\[0\].bbox: box .* has no area"):
        read_coco(results, images=fixtures / "coco_annotations.json")


def test_coco_string_image_ids_name_the_images():
    frames = read_coco([{"image_id": "1700000000.5.png", "category_id": 3, "bbox": [1, 2, 3, 4], "score": 0.5}])
    assert frames[0].image == "1700000000.5.png"
    assert frames[0].stamp == 1700000000.5


def test_csv_fixture_lists_empty_images(fixtures):
    frames = by_image(read_detections(fixtures / "detections.csv"))
    assert sorted(frames) == ["img_000", "img_001", "img_002"]
    assert frames["img_002"].detections == ()
    assert_allclose(frames["img_000"].detections[0].bbox_xyxy, TOMATO_000)
    assert [d.label for d in frames["img_000"].detections] == ["tomato", "leaf"]


def test_csv_with_stamps_and_semicolons(tmp_path):
    (tmp_path / "d.csv").write_text("timestamp;xmin;ymin;xmax;ymax;conf\n12.5;1;2;3;4;0.7\n12.5;5;6;7;8;\n13.0;1;1;2;2;0.1\n")
    frames = read_detections_csv(tmp_path / "d.csv")
    assert [f.stamp for f in frames] == [12.5, 13.0]
    assert [d.score for d in frames[0].detections] == [0.7, None]


def test_csv_errors(tmp_path):
    (tmp_path / "a.csv").write_text("image,x1,y1,x2\nimg.png,1,2,3\n")
    with pytest.raises(InputError, match=r"a.csv: header \['image', 'x1', 'y1', 'x2'\] lacks the column\(s\) \['y2'\]"):
        read_detections_csv(tmp_path / "a.csv")
    (tmp_path / "b.csv").write_text("image,x1,y1,x2,y2\nimg.png,1,2,3,four\n")
    with pytest.raises(InputError, match="b.csv: line 2: y2: expected a number, got 'four'"):
        read_detections_csv(tmp_path / "b.csv")
    (tmp_path / "c.csv").write_text("image,x1,y1,x2,y2\nimg.png,1,2,3,4,5\n")
    with pytest.raises(InputError, match="c.csv: line 2: 6 cells, the header has 5"):
        read_detections_csv(tmp_path / "c.csv")


def test_the_formats_agree(fixtures):
    """The three fixtures describe the same image 000: the same boxes, scores and labels."""
    yolo = by_image(read_detections(fixtures / "yolo_labels", image_size=(640, 480)))["img_000"].detections[:2]
    coco = by_image(read_detections(fixtures / "coco_results.json", images=fixtures / "coco_annotations.json"))[
        "img_000"
    ].detections
    csv = by_image(read_detections(fixtures / "detections.csv"))["img_000"].detections
    for a, b, c in zip(yolo, coco, csv):
        assert_allclose(a.bbox_xyxy, b.bbox_xyxy, atol=1e-9)
        assert_allclose(a.bbox_xyxy, c.bbox_xyxy, atol=1e-9)
        assert a.label == b.label == c.label and a.score == b.score == c.score


def test_filter_records_every_left_out_detection():
    dets = (
        Detection(np.array([0.0, 0, 2, 2]), 0.3, "tomato"),
        Detection(np.array([0.0, 0, 2, 2]), 0.9, "leaf"),
        Detection(np.array([0.0, 0, 2, 2]), None, "tomato"),
        Detection(np.array([0.0, 0, 2, 2]), 0.8, None),
        Detection(np.array([0.0, 0, 2, 2]), 0.7, "tomato"),
    )
    summary = ImportSummary()
    (out,) = filter_detections([ImageDetections("a.png", detections=dets)], min_score=0.5, labels=["tomato"], summary=summary)
    assert [d.score for d in out.detections] == [None, 0.7]
    assert summary.reasons() == {
        ("detection", "score below 0.5"): 1,
        ("detection", "label not in ['tomato']"): 1,
        ("detection", "no label"): 1,
    }
    assert any("no score and were kept" in n for n in summary.notes)
    with pytest.raises(InputError, match=r"--min-score \(min_score\): got 2.0, expected a value in \[0, 1\]"):
        filter_detections([], min_score=2)


def test_load_class_names_forms(tmp_path):
    assert load_class_names({"names": ["a", "b"]}) == {0: "a", 1: "b"}
    assert load_class_names({"0": "a", 2: "c"}) == {0: "a", 2: "c"}
    (tmp_path / "n.json").write_text('["x", "y"]')
    assert load_class_names(tmp_path / "n.json") == {0: "x", 1: "y"}
    with pytest.raises(InputError, match="class_names: expected a list of names or a mapping"):
        load_class_names(3)
