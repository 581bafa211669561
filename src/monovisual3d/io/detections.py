"""Detection readers: YOLO label files, COCO results JSON, plain CSV; score and label filters.

Every reader returns a list of :class:`ImageDetections`, one per image, with
boxes as ``bbox_xyxy`` in pixels of the image the detector saw (pixel
coordinates are continuous, the image's top-left corner is ``(0, 0)``, as
detectors report them). Matching them with camera poses is done by
:func:`monovisual3d.io.build_session`.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import as_array, as_float, as_int, expect_list, expect_object
from ..errors import InputError, excerpt
from ..session import Detection
from ._parse import check_rows, image_key, load_json, load_structured, read_table_text, read_text, stamp_from_name
from .summary import ImportSummary

DETECTION_FORMATS = ("yolo", "coco", "csv")


@dataclass(frozen=True)
class ImageDetections:
    """The detections of one image.

    Attributes
    ----------
    image : str or None, the image's file name (YOLO: the label file's stem)
    stamp : float or None, seconds (from the source, or a numeric file name)
    detections : tuple of Detection, boxes ``bbox_xyxy`` in pixels
    image_size : (width, height) or None, the size the boxes refer to when the source states it
    source : str or None, where they were read (file name)
    lines : tuple of str, where each detection was read (``FILE: line N``), for errors found after the import;
        empty when not known
    """

    image: str | None
    stamp: float | None = None
    detections: tuple[Detection, ...] = ()
    image_size: tuple[int, int] | None = None
    source: str | None = field(default=None, compare=False)
    lines: tuple[str, ...] = field(default=(), compare=False)

    @property
    def name(self) -> str:
        """A readable identifier: the image name, else the stamp."""
        if self.image is not None:
            return self.image if self.image.isprintable() else repr(self.image)  # messages stay one line
        return f"stamp {self.stamp:.6f}" if self.stamp is not None else "(unnamed image)"


# ---------------------------------------------------------------------- dispatch
def read_detections(
    source: str | Path,
    *,
    format: str | None = None,
    image_size: tuple[int, int] | None = None,
    class_names: Any = None,
    images: Any = None,
) -> list[ImageDetections]:
    """Read detections from a YOLO label folder/file, a COCO JSON or a CSV file.

    Parameters
    ----------
    source : path; a folder means YOLO labels (``*.txt``; a ``labels/`` subfolder is used when present)
    format : {"yolo", "coco", "csv"} or None to decide from the path
    image_size : (width, height), the size of the images (needed by YOLO's normalised boxes)
    class_names : class-id -> name map for numeric labels: a list, a dict or a file
        (Ultralytics ``data.yaml`` with ``names``, ``classes.txt`` one name per line, JSON)
    images : COCO only: the ``images`` list (or a COCO file holding it) when ``source`` is a bare results list

    Returns
    -------
    list of ImageDetections
    """
    path = Path(source)
    fmt = format.lower() if format else _detection_format(path)
    if fmt == "yolo":
        if image_size is None:
            raise InputError(f"{path}: YOLO boxes are normalised: the image size is needed (image_size=(w, h))")
        return read_yolo_labels(path, image_size, class_names=class_names)
    if fmt == "coco":
        return read_coco(path, images=images, class_names=class_names)
    if fmt == "csv":
        return read_detections_csv(path, class_names=class_names)
    raise InputError(f"{path}: --detections-format (format): got {excerpt(format)}, expected one of {list(DETECTION_FORMATS)}")


def _detection_format(path: Path) -> str:
    if not path.exists():
        raise InputError(f"{path}: file or folder not found")
    if path.is_dir():
        return "yolo"
    suffix = path.suffix.lower()
    if suffix == ".txt":
        return "yolo"
    if suffix == ".json":
        return "coco"
    if suffix in (".csv", ".tsv"):
        return "csv"
    raise InputError(
        f"{path}: cannot tell the detection format from the suffix {excerpt(suffix)}: "
        "pass --detections-format yolo, coco or csv (format=...)"
    )


# ---------------------------------------------------------------------- class names
def load_class_names(source: Any) -> dict[int, str]:
    """A class-id -> name map from a list, a dict or a file (YAML ``names:``, JSON, or one name per line).

    Examples
    --------
    >>> load_class_names(["leaf", "tomato"])
    {0: 'leaf', 1: 'tomato'}
    """
    where = "class_names"
    data = source
    if isinstance(source, (str, Path)):
        path = Path(source)
        where = str(path)
        if path.suffix.lower() in (".yaml", ".yml", ".json"):
            data = load_structured(path)
        else:
            data = [line.strip() for line in read_text(path).splitlines() if line.strip()]
    if isinstance(data, dict) and "names" in data:
        data = data["names"]
    if isinstance(data, (list, tuple)):
        return {i: _name(n, f"{where}[{i}]") for i, n in enumerate(data)}
    if isinstance(data, Mapping):
        return {as_int(k, f"{where} key {excerpt(k)}", minimum=0): _name(v, f"{where}[{excerpt(k)}]") for k, v in data.items()}
    raise InputError(f"{where}: expected a list of names or a mapping id -> name, got {type(data).__name__}")


def _name(value: Any, where: str) -> str:
    if isinstance(value, (dict, list)) or value is None:
        raise InputError(f"{where}: expected a class name, got {excerpt(value)}")
    return str(value)


def _label_for(raw: str | None, names: dict[int, str] | None) -> str | None:
    if raw is None:
        return None
    raw = raw.strip()
    if raw == "":
        return None
    if names and re.fullmatch(r"\d+", raw) and int(raw) in names:
        return names[int(raw)]
    return raw


# ---------------------------------------------------------------------- YOLO
def read_yolo_labels(source: str | Path, image_size: tuple[int, int], *, class_names: Any = None) -> list[ImageDetections]:
    """Read YOLO label files: ``class cx cy w h [conf]`` normalised to [0, 1], one file per image.

    Segmentation lines ``class x1 y1 x2 y2 ... [conf]`` (a polygon, normalised) give the
    polygon's bounding box and the polygon as the mask.

    Parameters
    ----------
    source : a ``.txt`` file or a folder of them (``classes.txt`` there is the class list)
    image_size : (width, height), pixels of the images the labels belong to
    class_names : see :func:`load_class_names`; labels stay the class number when absent

    Returns
    -------
    list of ImageDetections, image = the label file's stem, sorted by name
    """
    path = Path(source)
    if not path.exists():
        raise InputError(f"{path}: file or folder not found")
    if path.is_dir():
        files = sorted(p for p in path.glob("*.txt") if p.name != "classes.txt")
        if not files and (path / "labels").is_dir():
            return read_yolo_labels(path / "labels", image_size, class_names=class_names)
        if class_names is None and (path / "classes.txt").is_file():
            class_names = path / "classes.txt"
        if not files:
            raise InputError(f"{path}: no YOLO label files (*.txt) in this folder")
    else:
        files = [path]
    names = load_class_names(class_names) if class_names is not None else None
    W, H = (as_int(v, f"image_size[{i}]", minimum=1) for i, v in enumerate(image_size))
    out = []
    for f in files:
        dets, wheres = [], []
        for lineno, line in enumerate(read_table_text(f).splitlines(), start=1):
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            wheres.append(f"{f}: line {lineno}")
            dets.append(_yolo_line(text.split(), W, H, names, wheres[-1]))
        key = f.stem
        out.append(
            ImageDetections(image=key, stamp=stamp_from_name(key), detections=tuple(dets), source=str(f), lines=tuple(wheres))
        )
    return out


def _yolo_line(parts: list[str], W: int, H: int, names: dict[int, str] | None, where: str) -> Detection:
    n = len(parts)
    if n < 5:
        raise InputError(f"{where}: {n} values, expected 'class cx cy w h [conf]' (normalised) or a polygon")
    cls = as_int(parts[0], f"{where}: class", minimum=0)
    values = [as_float(p, f"{where}: value {i + 2}") for i, p in enumerate(parts[1:])]
    score = None
    mask = None
    if n in (5, 6):
        cx, cy, w, h = values[:4]
        if n == 6:
            score = values[4]
        if w <= 0 or h <= 0:
            raise InputError(f"{where}: box width and height must be positive, got w={w:g}, h={h:g}")
        box = [(cx - 0.5 * w) * W, (cy - 0.5 * h) * H, (cx + 0.5 * w) * W, (cy + 0.5 * h) * H]
    else:
        coords = values
        if len(coords) % 2 == 1:
            coords, score = coords[:-1], coords[-1]
        with np.errstate(over="ignore", invalid="ignore"):  # huge values: inf, rejected by _finite_box
            pts = np.asarray(coords, dtype=float).reshape(-1, 2) * [W, H]
        if len(pts) < 3:
            raise InputError(f"{where}: a polygon needs at least 3 points, got {len(pts)}")
        box = [float(pts[:, 0].min()), float(pts[:, 1].min()), float(pts[:, 0].max()), float(pts[:, 1].max())]
        mask = {"polygon": pts.tolist()}
    box = _finite_box(box, where)
    if score is not None and not 0.0 <= score <= 1.0:
        raise InputError(f"{where}: confidence {score:g}, expected a value in [0, 1]")
    return Detection(np.asarray(box), score=score, label=_label_for(str(cls), names), mask=mask)


def _finite_box(box: Sequence[float], where: str) -> list[float]:
    arr = np.asarray(box, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{where}: box {arr.tolist()} is not finite")
    if arr[2] <= arr[0] or arr[3] <= arr[1]:
        raise InputError(f"{where}: box {arr.tolist()} has no area (expected x1 < x2 and y1 < y2)")
    return arr.tolist()


# ---------------------------------------------------------------------- COCO
def read_coco(
    source: str | Path | dict[str, Any] | list[Any], *, images: Any = None, class_names: Any = None
) -> list[ImageDetections]:
    """Read COCO detection results or annotations.

    Accepts a dict with ``images`` (``id``, ``file_name``, ``width``, ``height``),
    ``annotations`` (or ``results``/``detections``) and optional ``categories``,
    or a bare results list (``image_id, category_id, bbox [x, y, w, h], score``)
    together with ``images`` (the list, or a COCO file that holds it). Results
    may carry ``segmentation`` (polygons or RLE), kept as the mask.

    Returns
    -------
    list of ImageDetections, one per image of the images list (images without results included)
    """
    where = "coco"
    data = source
    if isinstance(source, (str, Path)):
        where = str(source)
        data = load_json(read_text(source), where)
    image_list = None
    categories: dict[int, str] = {}
    if isinstance(data, dict):
        image_list = data.get("images")
        results = next((data[k] for k in ("annotations", "results", "detections") if k in data), None)
        if results is None:
            raise InputError(f"{where}: no 'annotations' (or 'results') list")
        categories = _coco_categories(data, where)
    elif isinstance(data, list):
        results = data
    else:
        raise InputError(f"{where}: expected a COCO object or a list of results, got {type(data).__name__}")
    if images is not None:
        image_list, categories = _coco_images_argument(images, categories, where)
    results = expect_list(results, f"{where}: annotations")
    check_rows(len(results), where, "annotations")
    names = load_class_names(class_names) if class_names is not None else None
    by_id = _coco_image_list(image_list, where) if image_list is not None else {}
    order: list[Any] = list(by_id)
    dets: dict[Any, list[Detection]] = {k: [] for k in by_id}
    for j, r in enumerate(results):
        w_r = f"{where}: annotations[{j}]"
        r = expect_object(r, w_r)
        for k in ("image_id", "bbox"):
            if k not in r:
                raise InputError(f"{w_r}.{k}: missing field")
        iid = _coco_id(r["image_id"], f"{w_r}.image_id")
        if iid not in by_id:
            if image_list is not None:
                raise InputError(f"{w_r}.image_id: {excerpt(iid)} is not in the images list")
            if not isinstance(iid, str):
                raise InputError(
                    f"{w_r}.image_id: numeric id {excerpt(iid)} and no images list: give the COCO file that has the images "
                    "with --coco-images FILE (images=... in read_coco, coco_images=... in import_session)"
                )
            by_id[iid] = ImageDetections(image=iid, stamp=stamp_from_name(iid), source=where)
            dets[iid] = []
            order.append(iid)
        dets[iid].append(_coco_detection(r, w_r, categories, names))
    return [replace(by_id[k], detections=tuple(dets[k])) for k in order]


def _coco_images_argument(images: Any, categories: dict[int, str], where: str) -> tuple[Any, dict[int, str]]:
    """The ``images`` of :func:`read_coco` (a list, a COCO dict or its file): the images list and the categories.

    The categories of a COCO ``images`` file are added to ``categories`` (which win on equal ids).
    """
    image_list = images
    if isinstance(images, (str, Path)):
        images = load_json(read_text(images), str(images))
    if isinstance(images, dict):
        if "images" not in images:
            raise InputError(f"{where}: the images file has no 'images' list")
        image_list = images["images"]
        categories = {**_coco_categories(images, "images"), **categories}
    else:
        image_list = images
    return image_list, categories


def _coco_detection(r: dict[str, Any], w_r: str, categories: dict[int, str], names: dict[int, str] | None) -> Detection:
    """One COCO result or annotation ``r`` (``bbox [x, y, w, h]``, ``score``, ``category_id``, ``segmentation``)."""
    x, y, w, h = as_array(r["bbox"], f"{w_r}.bbox", size=4).ravel().tolist()
    box = _finite_box([x, y, x + w, y + h], f"{w_r}.bbox")
    score = None
    if r.get("score") is not None:
        score = as_float(r["score"], f"{w_r}.score")
        if not 0.0 <= score <= 1.0:
            raise InputError(f"{w_r}.score: {score:g}, expected a value in [0, 1]")
    label = None
    if r.get("category_id") is not None:
        cid = as_int(r["category_id"], f"{w_r}.category_id")
        label = categories.get(cid) or (names or {}).get(cid) or str(cid)
    mask = _coco_mask(r.get("segmentation"), f"{w_r}.segmentation")
    return Detection(np.asarray(box), score=score, label=label, mask=mask)


def _coco_image_list(image_list: Any, where: str) -> dict[Any, ImageDetections]:
    """The images of a COCO ``images`` list by id, in file order, still without detections."""
    by_id: dict[Any, ImageDetections] = {}
    for i, im in enumerate(expect_list(image_list, f"{where}: images")):
        w_im = f"{where}: images[{i}]"
        im = expect_object(im, w_im)
        if "id" not in im:
            raise InputError(f"{w_im}.id: missing field")
        iid = _coco_id(im["id"], f"{w_im}.id")
        if iid in by_id:
            raise InputError(f"{w_im}.id: duplicate image id {excerpt(iid)}")
        fname = im.get("file_name", str(iid))
        if not isinstance(fname, str) or not fname:
            raise InputError(f"{w_im}.file_name: expected a file name, got {excerpt(fname)}")
        size = None
        if im.get("width") is not None and im.get("height") is not None:
            size = (as_int(im["width"], f"{w_im}.width", minimum=1), as_int(im["height"], f"{w_im}.height", minimum=1))
        stamp = im.get("stamp", im.get("timestamp"))
        stamp = as_float(stamp, f"{w_im}.stamp") if stamp is not None else stamp_from_name(fname)
        by_id[iid] = ImageDetections(image=fname, stamp=stamp, image_size=size, source=where)
    return by_id


def _coco_categories(data: dict[str, Any], where: str) -> dict[int, str]:
    out: dict[int, str] = {}
    if data.get("categories") is not None:
        for i, c in enumerate(expect_list(data["categories"], f"{where}: categories")):
            c = expect_object(c, f"{where}: categories[{i}]")
            if "id" in c and "name" in c:
                out[as_int(c["id"], f"{where}: categories[{i}].id")] = _name(c["name"], f"{where}: categories[{i}].name")
    return out


def _coco_id(value: Any, where: str) -> Any:
    if isinstance(value, str):
        if not value:
            raise InputError(f"{where}: empty id")
        return value
    return as_int(value, where)


def _coco_mask(seg: Any, where: str) -> dict[str, Any] | None:
    if seg is None or seg == []:
        return None
    if isinstance(seg, dict):
        if "counts" in seg and "size" in seg:
            size = as_array(seg["size"], f"{where}.size", size=2)
            counts = seg["counts"]
            if not isinstance(counts, (str, list)):
                raise InputError(f"{where}.counts: expected an RLE string or list")
            return {"size": [int(v) for v in size], "counts": counts}
        raise InputError(f"{where}: expected polygons or RLE {{'size', 'counts'}}")
    if isinstance(seg, list):
        polys = seg if seg and isinstance(seg[0], list) else [seg]
        longest = max(polys, key=len)
        pts = as_array(longest, f"{where}[0]")
        if pts.size % 2 or pts.size < 6:
            raise InputError(f"{where}: a polygon needs an even number (>= 6) of coordinates, got {pts.size}")
        return {"polygon": pts.reshape(-1, 2).tolist()}
    raise InputError(f"{where}: expected polygons or RLE, got {type(seg).__name__}")


# ---------------------------------------------------------------------- CSV
_CSV_COLUMNS = {
    "image": ("image", "file", "filename", "file_name", "image_name", "image_file", "path"),
    "stamp": ("stamp", "timestamp", "time", "t"),
    "x1": ("x1", "xmin", "x_min", "left"),
    "y1": ("y1", "ymin", "y_min", "top"),
    "x2": ("x2", "xmax", "x_max", "right"),
    "y2": ("y2", "ymax", "y_max", "bottom"),
    "score": ("score", "conf", "confidence"),
    "label": ("label", "class", "class_name", "name", "category"),
}


def read_detections_csv(source: str | Path, *, class_names: Any = None) -> list[ImageDetections]:
    """Read a CSV with a header ``image, x1, y1, x2, y2, score, label`` (pixels).

    ``score`` and ``label`` are optional; an optional ``stamp`` column (seconds)
    may replace or complement ``image``. A row with an image but empty box
    cells lists an image without detections.

    Returns
    -------
    list of ImageDetections, in order of first appearance
    """
    path = Path(source)
    rows, col = read_csv_table(path, _CSV_COLUMNS, required=("x1", "y1", "x2", "y2"))
    if "image" not in col and "stamp" not in col:
        raise InputError(f"{path}: header: needs an 'image' or a 'stamp' column")
    names = load_class_names(class_names) if class_names is not None else None
    groups: dict[Any, list[Detection]] = {}
    wheres: dict[Any, list[str]] = {}
    meta: dict[Any, tuple[str | None, float | None]] = {}
    for lineno, row in rows:
        where = f"{path}: line {lineno}"
        image = row[col["image"]].strip() if "image" in col else None
        stamp_text = row[col["stamp"]].strip() if "stamp" in col else ""
        stamp = as_float(stamp_text, f"{where}: stamp") if stamp_text else None
        if not image and stamp is None:
            raise InputError(f"{where}: neither an image name nor a stamp")
        if image and stamp is None:
            stamp = stamp_from_name(image)
        key = image_key(image) if image else stamp
        if key not in groups:
            groups[key], wheres[key] = [], []
            meta[key] = (image or None, stamp)
        cells = [row[col[k]].strip() for k in ("x1", "y1", "x2", "y2")]
        if not any(cells):
            continue
        box = _finite_box([as_float(c, f"{where}: {k}") for c, k in zip(cells, ("x1", "y1", "x2", "y2"))], where)
        score = None
        if "score" in col and row[col["score"]].strip():
            score = as_float(row[col["score"]], f"{where}: score")
            if not 0.0 <= score <= 1.0:
                raise InputError(f"{where}: score {score:g}, expected a value in [0, 1]")
        label = _label_for(row[col["label"]], names) if "label" in col else None
        groups[key].append(Detection(np.asarray(box), score=score, label=label))
        wheres[key].append(where)
    if not groups:
        raise InputError(f"{path}: no rows after the header")
    return [
        ImageDetections(image=meta[k][0], stamp=meta[k][1], detections=tuple(v), source=str(path), lines=tuple(wheres[k]))
        for k, v in groups.items()
    ]


def read_csv_table(
    path: Path, columns: Mapping[str, Sequence[str]], required: Iterable[str] = ()
) -> tuple[list[tuple[int, list[str]]], dict[str, int]]:
    """Rows of a CSV (comma, semicolon or tab separated) and the index of each known column.

    Returns
    -------
    rows : list of (line number, cells), every row padded to the header's length
    col : dict canonical column name -> index
    """
    text = read_table_text(path)
    lines = [(i, line) for i, line in enumerate(text.splitlines(), start=1) if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise InputError(f"{path}: empty, expected a header line and rows")
    header_line = lines[0][1]
    delim = max((",", ";", "\t"), key=header_line.count)
    if header_line.count(delim) == 0:
        delim = ","
    try:
        parsed = list(csv.reader(io.StringIO("\n".join(line for _, line in lines)), delimiter=delim))
    except csv.Error as exc:
        raise InputError(f"{path}: not valid CSV: {exc}") from None
    if len(parsed) != len(lines):
        raise InputError(f"{path}: a quoted cell spans several lines; expected one row per line")
    header = [h.strip().lower() for h in parsed[0]]
    col: dict[str, int] = {}
    for canon, aliases in columns.items():
        for a in aliases:
            if a in header:
                col[canon] = header.index(a)
                break
    missing = [c for c in required if c not in col]
    if missing:
        raise InputError(f"{path}: header {excerpt(header[:10], 120)} lacks the column(s) {missing}")
    rows = []
    for (lineno, _), cells in zip(lines[1:], parsed[1:]):
        if len(cells) > len(header):
            raise InputError(f"{path}: line {lineno}: {len(cells)} cells, the header has {len(header)}")
        rows.append((lineno, cells + [""] * (len(header) - len(cells))))
    return rows, col


# ---------------------------------------------------------------------- filters
def filter_detections(
    frames: Sequence[ImageDetections],
    *,
    min_score: float | None = None,
    labels: Iterable[str] | None = None,
    summary: ImportSummary | None = None,
) -> list[ImageDetections]:
    """Keep detections with ``score >= min_score`` and a label among ``labels``.

    Detections without a score are kept (and counted in a note); with a label
    filter, detections without a label are left out. Every detection left out
    is recorded in ``summary`` with its reason.

    Examples
    --------
    >>> f = ImageDetections("a.png", detections=(Detection(np.array([0., 0, 2, 2]), 0.3, "leaf"),
    ...                                          Detection(np.array([1., 1, 3, 3]), 0.9, "tomato")))
    >>> [d.label for d in filter_detections([f], min_score=0.5)[0].detections]
    ['tomato']
    """
    if min_score is not None:
        min_score = as_float(min_score, "--min-score (min_score)")
        if not 0.0 <= min_score <= 1.0:
            raise InputError(f"--min-score (min_score): got {min_score}, expected a value in [0, 1]")
    wanted = None if labels is None else {str(x) for x in labels}
    if wanted is not None and not wanted:
        wanted = None
    out = []
    unscored = 0
    for f in frames:
        keep, kept_lines = [], []
        for j, d in enumerate(f.detections):
            item = f"{f.name} #{j}"
            if wanted is not None and d.label not in wanted:
                reason = "no label" if d.label is None else f"label not in {sorted(wanted)}"
                if summary is not None:
                    summary.skip("detection", item, reason, f"label {excerpt(d.label)}", warn=False)
                continue
            if min_score is not None:
                if d.score is None:
                    unscored += 1
                elif d.score < min_score:
                    if summary is not None:
                        summary.skip("detection", item, f"score below {min_score:g}", f"score {d.score:.3g}", warn=False)
                    continue
            keep.append(d)
            if j < len(f.lines):
                kept_lines.append(f.lines[j])
        out.append(replace(f, detections=tuple(keep), lines=tuple(kept_lines) if len(kept_lines) == len(keep) else ()))
    if unscored and summary is not None:
        summary.note(f"{unscored} detections have no score and were kept by the score threshold")
    return out


__all__ = [
    "DETECTION_FORMATS",
    "ImageDetections",
    "filter_detections",
    "load_class_names",
    "read_coco",
    "read_detections",
    "read_detections_csv",
    "read_yolo_labels",
]
