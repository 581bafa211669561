"""Ultralytics adapter (extra ``[yolo]``): run a YOLO model on images, get boxes and masks.

The model can be any object with Ultralytics' ``predict`` interface (a loaded
``ultralytics.YOLO``), or a weights path, which is then loaded with
``ultralytics.YOLO`` (imported only then). Results are read by duck typing:
``boxes.xyxy``, ``boxes.conf``, ``boxes.cls``, ``names``, ``masks.xy``,
``orig_shape`` and ``path``, as tensors or arrays.

Boxes are in pixels of the original image (Ultralytics undoes its letterbox
resize), continuous coordinates with the top-left image corner at ``(0, 0)``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._extras import require
from ..errors import InputError, excerpt
from ..session import Detection
from ._parse import stamp_from_name
from .detections import ImageDetections


def load_yolo_model(weights: str | Path) -> Any:
    """``ultralytics.YOLO(weights)``; ImportError naming the ``[yolo]`` extra when Ultralytics is missing."""
    ultralytics = require("ultralytics", "yolo")
    return ultralytics.YOLO(str(weights))


def detect_with_ultralytics(
    model: Any,
    images: Iterable[str | Path | Any],
    *,
    masks: bool = True,
    **predict_options: Any,
) -> list[ImageDetections]:
    """Run an Ultralytics model on images and return their detections.

    Parameters
    ----------
    model : a loaded model with ``predict(source, **options)``, or a weights path (``yolov8n.pt``)
    images : image paths (or arrays, named ``image<i>``)
    masks : keep segmentation masks as polygons (segmentation models)
    **predict_options : passed to ``model.predict`` (``conf=0.25``, ``classes=[...]``, ``imgsz=...``)

    Returns
    -------
    list of ImageDetections, one per image, with ``image`` the file name and ``image_size`` the original size

    Examples
    --------
    >>> from monovisual3d.io.yolo import detect_with_ultralytics  # doctest: +SKIP
    >>> frames = detect_with_ultralytics("yolov8n-seg.pt", sorted(Path("images").glob("*.png")), conf=0.5)  # doctest: +SKIP
    """
    if isinstance(model, (str, Path)):
        model = load_yolo_model(model)
    if not hasattr(model, "predict"):
        raise InputError(f"model: expected an Ultralytics model (with .predict) or a weights path, got {type(model).__name__}")
    predict_options.setdefault("verbose", False)
    out = []
    for i, image in enumerate(images):
        name = Path(image).name if isinstance(image, (str, Path)) else f"image{i}"
        source = str(image) if isinstance(image, Path) else image
        results = list(model.predict(source, **predict_options))
        if len(results) != 1:
            raise InputError(f"{name}: the model returned {len(results)} results for one image, expected 1")
        out.append(image_detections_from_result(results[0], name, masks=masks))
    return out


def image_detections_from_result(result: Any, image: str | None = None, *, masks: bool = True) -> ImageDetections:
    """Convert one Ultralytics ``Results`` object to :class:`ImageDetections`.

    Parameters
    ----------
    result : an Ultralytics Results (or any object with the same attributes)
    image : file name; by default the result's ``path``
    masks : keep ``masks.xy`` polygons

    Returns
    -------
    ImageDetections
    """
    if image is None:
        path = getattr(result, "path", None)
        image = Path(str(path)).name if path else None
    where = f"ultralytics result for {image or 'an image'}"
    names = getattr(result, "names", None) or {}
    size = _image_size(getattr(result, "orig_shape", None), where)
    boxes = getattr(result, "boxes", None)
    if boxes is None:
        return ImageDetections(image=image, stamp=stamp_from_name(image) if image else None, image_size=size)
    xyxy = _array(getattr(boxes, "xyxy", None), f"{where}: boxes.xyxy")
    if xyxy.size % 4:
        raise InputError(f"{where}: boxes.xyxy has shape {list(xyxy.shape)}, expected (N, 4)")
    xyxy = xyxy.reshape(-1, 4)
    n = len(xyxy)
    conf = _array(getattr(boxes, "conf", None), f"{where}: boxes.conf", n) if n else np.zeros(0)
    cls = _array(getattr(boxes, "cls", None), f"{where}: boxes.cls", n) if n else np.zeros(0)
    polys: Sequence[Any] | None = None
    mask_obj = getattr(result, "masks", None)
    if masks and mask_obj is not None and n:
        polys = list(getattr(mask_obj, "xy", []) or [])
        if len(polys) != n:
            raise InputError(f"{where}: {len(polys)} masks for {n} boxes")
    dets = []
    for i in range(n):
        x1, y1, x2, y2 = (float(v) for v in xyxy[i])
        if not (x2 > x1 and y2 > y1):
            raise InputError(f"{where}: box {i} {[x1, y1, x2, y2]} has no area")
        score = float(conf[i])
        if not 0.0 <= score <= 1.0:
            raise InputError(f"{where}: box {i} confidence {score:g}, expected [0, 1]")
        c = int(round(float(cls[i])))
        label = str(names.get(c, c)) if isinstance(names, dict) else str(c)
        mask = None
        if polys is not None:
            pts = _array(polys[i], f"{where}: masks.xy[{i}]").reshape(-1, 2) if np.size(polys[i]) else np.zeros((0, 2))
            if len(pts) >= 3:
                mask = {"polygon": pts.tolist()}
        dets.append(Detection(np.array([x1, y1, x2, y2]), score=score, label=label, mask=mask))
    return ImageDetections(image=image, stamp=stamp_from_name(image) if image else None, detections=tuple(dets), image_size=size)


def _to_numpy(x: Any) -> Any:
    """Tensors (torch, possibly on a GPU) or arrays to numpy."""
    if hasattr(x, "detach"):
        x = x.detach()
    if hasattr(x, "cpu"):
        x = x.cpu()
    if hasattr(x, "numpy"):
        x = x.numpy()
    return x


def _array(x: Any, where: str, n: int | None = None) -> NDArray[np.float64]:
    if x is None:
        raise InputError(f"{where}: missing")
    try:
        arr = np.asarray(_to_numpy(x), dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: not numeric") from None
    if n is not None:
        arr = arr.ravel()
        if arr.size != n:
            raise InputError(f"{where}: {arr.size} values for {n} boxes")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{where}: contains NaN or infinity")
    return arr


__all__ = ["detect_with_ultralytics", "image_detections_from_result", "load_yolo_model"]


def _image_size(shape: Any, where: str) -> tuple[int, int] | None:
    """``(width, height)`` from a result's ``orig_shape`` ``(height, width, ...)``, or None without one."""
    if shape is None:
        return None
    try:
        h, w = (int(v) for v in tuple(shape)[:2])
    except (TypeError, ValueError):
        raise InputError(f"{where}: orig_shape {excerpt(shape)} is not (height, width)") from None
    if h <= 0 or w <= 0:
        raise InputError(f"{where}: orig_shape {excerpt(shape)} is not a positive (height, width)")
    return (w, h)
