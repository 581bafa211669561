"""The Ultralytics adapter, tested with duck-typed fakes of its model and Results (Ultralytics is not installed)."""

from __future__ import annotations

import sys
from pathlib import Path

import io_scene as scene
import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.errors import InputError
from monovisual3d.io import build_session, detect_with_ultralytics, image_detections_from_result, read_poses


class FakeTensor:
    """Like a torch tensor on a GPU: must go through .cpu().numpy()."""

    def __init__(self, values):
        self._values = np.asarray(values, dtype=np.float32)

    def cpu(self):
        return FakeArray(self._values)

    def __len__(self):
        return len(self._values)

    def __array__(self, *args, **kwargs):  # numpy conversion of a GPU tensor fails in torch
        raise TypeError("can't convert cuda tensor to numpy")


class FakeArray:
    def __init__(self, values):
        self._values = values

    def numpy(self):
        return self._values


class FakeBoxes:
    def __init__(self, xyxy, conf, cls):
        self.xyxy, self.conf, self.cls = FakeTensor(xyxy), FakeTensor(conf), FakeTensor(cls)

    def __len__(self):
        return len(self.xyxy)


class FakeMasks:
    def __init__(self, polygons):
        self.xy = [np.asarray(p, dtype=np.float32) for p in polygons]


class FakeResult:
    def __init__(self, path, boxes, masks=None, shape=(480, 640)):
        self.path, self.boxes, self.masks, self.orig_shape = path, boxes, masks, shape
        self.names = {0: "tomato", 1: "leaf"}


def ellipse(box, n=24):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    cx, cy, a, b = (box[0] + box[2]) / 2, (box[1] + box[3]) / 2, (box[2] - box[0]) / 2, (box[3] - box[1]) / 2
    return np.column_stack([cx + a * np.cos(t), cy + b * np.sin(t)])


class FakeModel:
    """Answers predict() with the scene's sphere boxes (plus one leaf) for images named img_00i.png."""

    def __init__(self):
        self.calls = []

    def predict(self, source, **options):
        self.calls.append((source, options))
        i = int(Path(source).stem.split("_")[1])
        boxes = scene.view_boxes(scene.CAMERA, scene.camera_poses()[i]) + [np.array([40.0, 300.0, 90.0, 340.0])]
        conf = scene.scores() + [0.99]
        cls = [0, 0, 0, 1]
        return [FakeResult(str(source), FakeBoxes(boxes, conf, cls), FakeMasks([ellipse(b) for b in boxes]))]


def test_adapter_gives_boxes_masks_and_a_session(tmp_path):
    model = FakeModel()
    images = [tmp_path / f"img_{i:03d}.png" for i in range(4)]
    frames = detect_with_ultralytics(model, images, conf=0.5, imgsz=640)
    assert model.calls[0] == (str(images[0]), {"conf": 0.5, "imgsz": 640, "verbose": False})
    assert [f.image for f in frames] == [p.name for p in images]
    assert all(f.image_size == (640, 480) for f in frames)
    first = frames[0].detections
    assert [d.label for d in first] == ["tomato", "tomato", "tomato", "leaf"]
    assert_allclose([d.score for d in first], scene.scores() + [0.99], atol=1e-6)
    assert len(first[0].mask["polygon"]) == 24
    scene.write_pose_csv(tmp_path / "poses.csv", scene.camera_poses())
    result = build_session(scene.CAMERA, read_poses(tmp_path / "poses.csv"), frames, labels=["tomato"])
    ref = scene.direct_session_dict()
    for v, r in zip(result.session.views, ref["views"]):
        assert_allclose(v.boxes_xyxy, [d["bbox_xyxy"] for d in r["detections"]], atol=1e-3)  # float32 tensors
        assert v.detections[0].mask is not None
    assert result.summary.reasons() == {("detection", "label not in ['tomato']"): 4}


def test_weights_path_needs_the_yolo_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ultralytics", None)
    with pytest.raises(ImportError, match=r"pip install 'monovisual3d\[yolo\]'"):
        detect_with_ultralytics("yolov8n.pt", ["a.png"])


def test_result_without_boxes_and_bad_results():
    empty = image_detections_from_result(FakeResult("/data/1700000000.5.png", None))
    assert empty.detections == () and empty.stamp == 1700000000.5 and empty.image == "1700000000.5.png"
    none = image_detections_from_result(FakeResult("a.png", FakeBoxes(np.zeros((0, 4)), [], [])))
    assert none.detections == ()
    bad = FakeResult("a.png", FakeBoxes([[10, 10, 5, 20]], [0.5], [0]))
    with pytest.raises(InputError, match=r"ultralytics result for a.png: box 0 \[10.0, 10.0, 5.0, 20.0\] has no area"):
        image_detections_from_result(bad)
    bad = FakeResult("a.png", FakeBoxes([[1, 1, 5, 5]], [0.5], [0]), FakeMasks([]))
    with pytest.raises(InputError, match="0 masks for 1 boxes"):
        image_detections_from_result(bad)
    bad = FakeResult("a.png", FakeBoxes([[1, np.nan, 5, 5]], [0.5], [0]))
    with pytest.raises(InputError, match="boxes.xyxy: contains NaN or infinity"):
        image_detections_from_result(bad)
    with pytest.raises(InputError, match="model: expected an Ultralytics model"):
        detect_with_ultralytics(object(), ["a.png"])
