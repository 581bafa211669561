"""Photorealistic pipeline: render views with MuJoCo, detect fruit by colour, build a session.

Pixels -> boxes -> 3D without a robot: :func:`render_views` renders each pose
(:class:`~monovisual3d.sim.mujoco_render.MujocoRenderer`), runs the colour
detector (:func:`monovisual3d.vision.detect_colour`) on the RGB image and returns
a :class:`~monovisual3d.session.Session` ready for :func:`monovisual3d.localize`.
Needs the extras ``[sim]`` and ``[vision]``.

Files written to ``output_dir`` (so people can look at what the camera saw)::

    session.json          the session (detections from the colour detector)
    truth.json            the fruit (ground truth for ``monovisual3d evaluate``)
    scene.json            the whole scene, occluders included
    model.xml             the MJCF model (open it in MuJoCo's viewer)
    boxes_truth.json      per view and fruit: box of the visible pixels and their count
    images/view_NNN_rgb.png      what the camera saw
    images/view_NNN_labels.png   16-bit label image: 0 background, i + 1 fruit i
    images/view_NNN_overlay.png  RGB with detector boxes (yellow) and true boxes (cyan)
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._extras import require
from ..camera import Camera
from ..errors import InputError
from ..frames import check_transform
from ..session import Detection, Session, View
from ..vision.boxes import boxes_from_label_image
from ..vision.colour import ColourDetectorConfig, detect_colour
from .mujoco_render import MujocoRenderer, RenderConfig, RenderedView, scene_lowest_z
from .scene import Scene


def check_poses(poses: Sequence[ArrayLike] | ArrayLike) -> list[NDArray[np.float64]]:
    """Validate camera poses: a sequence of (4, 4) ``T_base_optical`` or an array (N, 4, 4)."""
    arr = np.asarray(poses, dtype=float)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (4, 4):
        raise InputError(f"poses: expected T_base_optical matrices of shape (N, 4, 4), got {list(arr.shape)}")
    if len(arr) == 0:
        raise InputError("poses: empty, expected at least one camera pose")
    return [check_transform(T, where=f"poses[{i}]") for i, T in enumerate(arr)]


def render_views(
    scene: Scene,
    camera: Camera,
    poses: Sequence[ArrayLike] | ArrayLike,
    output_dir: str | Path | None = None,
    *,
    render_config: RenderConfig | None = None,
    detector_config: ColourDetectorConfig | None = None,
) -> tuple[Session, list[RenderedView]]:
    """Render a scene from each pose, detect red fruit and build the session.

    Parameters
    ----------
    scene : Scene
    camera : Camera, without distortion
    poses : sequence of array_like (4, 4), or array (N, 4, 4), ``T_base_optical`` per view
    output_dir : path or None, where to save images, session and truth (created if missing)
    render_config : RenderConfig or None; with ``ground_z`` None the ground goes
        ``ground_margin`` below both the scene and the lowest camera
    detector_config : ColourDetectorConfig or None

    Returns
    -------
    session : Session, one view per pose with the colour detector's boxes
    images : list of RenderedView, the RGB and label images per view

    Examples
    --------
    >>> from monovisual3d.frames import look_at
    >>> from monovisual3d.sim.scene import Sphere
    >>> scene = Scene((Sphere(np.array([0.5, 0.0, 0.3]), 0.03),))
    >>> cam = Camera.from_hfov(320, 240, 60.0)
    >>> session, images = render_views(scene, cam, [look_at([0.0, 0.0, 0.3], [0.5, 0.0, 0.3])])  # doctest: +SKIP
    >>> len(session.views[0].detections)  # doctest: +SKIP
    1
    """
    Ts = check_poses(poses)
    cfg = _ground_below_cameras(render_config or RenderConfig(), scene, Ts)
    det_cfg = detector_config or ColourDetectorConfig()
    out = Path(output_dir) if output_dir is not None else None
    if out is not None:
        (out / "images").mkdir(parents=True, exist_ok=True)

    images: list[RenderedView] = []
    views: list[View] = []
    truth_boxes: list[dict[str, Any]] = []
    with MujocoRenderer(scene, camera, cfg) as renderer:
        for i, T in enumerate(Ts):
            image = renderer.render(T)
            dets = tuple(detect_colour(image.rgb, det_cfg))
            name = f"images/view_{i:03d}_rgb.png"
            images.append(image)
            views.append(View(T_base_optical=T, detections=dets, image=name if out is not None else None))
            if out is not None:
                truth_boxes.append(_save_view(out, i, name, image, dets, len(scene.fruits)))
        xml = renderer.xml
    session = Session(camera=camera, views=tuple(views))
    if out is not None:
        _write_files(out, session, scene, xml, truth_boxes)
    return session, images


def _ground_below_cameras(cfg: RenderConfig, scene: Scene, Ts: list[NDArray[np.float64]]) -> RenderConfig:
    """With ``ground_z`` unset, the ground ``ground_margin`` below both the scene and the lowest camera."""
    if not cfg.ground or cfg.ground_z is not None:
        return cfg
    lowest = min(scene_lowest_z(scene), min(float(T[2, 3]) for T in Ts))
    return replace(cfg, ground_z=lowest - cfg.ground_margin)


def _save_view(
    out: Path, index: int, name: str, image: RenderedView, detections: tuple[Detection, ...], n_fruit: int
) -> dict[str, Any]:
    """Write the view's images; returns its ``boxes_truth.json`` entry (box of each fruit's visible pixels and their count)."""
    boxes, pixels = boxes_from_label_image(image.labels, n_fruit)
    _save_view_images(out, index, image, detections, boxes)
    return {
        "image": name,
        "fruit": [
            {"index": k, "bbox_xyxy": None if np.isnan(b[0]) else b.tolist(), "pixels": int(p)}
            for k, (b, p) in enumerate(zip(boxes, pixels))
        ],
    }


def _write_files(out: Path, session: Session, scene: Scene, xml: str, truth_boxes: list[dict[str, Any]]) -> None:
    """``session.json``, ``truth.json``, ``scene.json``, ``model.xml`` and ``boxes_truth.json`` (see the module docstring)."""
    session.to_json(out / "session.json")
    (out / "truth.json").write_text(json.dumps(scene.truth_dict(), indent=2) + "\n")
    scene.save(out / "scene.json")
    (out / "model.xml").write_text(xml + "\n")
    (out / "boxes_truth.json").write_text(json.dumps({"views": truth_boxes}, indent=2) + "\n")


def _save_view_images(
    out: Path, index: int, image: RenderedView, detections: tuple[Detection, ...], truth_boxes: NDArray[np.float64]
) -> None:
    cv2 = require("cv2", "vision")
    stem = out / "images" / f"view_{index:03d}"
    bgr = np.ascontiguousarray(image.rgb[..., ::-1])
    cv2.imwrite(f"{stem}_rgb.png", bgr)
    cv2.imwrite(f"{stem}_labels.png", (image.labels + 1).astype(np.uint16))
    overlay = bgr.copy()
    for box in truth_boxes:
        if np.all(np.isfinite(box)):
            x1, y1, x2, y2 = (int(round(v)) for v in box)
            cv2.rectangle(overlay, (x1, y1), (x2 - 1, y2 - 1), (255, 255, 0), 1)  # cyan (BGR)
    for det in detections:
        x1, y1, x2, y2 = (int(round(v)) for v in det.bbox_xyxy)
        cv2.rectangle(overlay, (x1 - 1, y1 - 1), (x2, y2), (0, 255, 255), 1)  # yellow, just outside the box
    cv2.imwrite(f"{stem}_overlay.png", overlay)


__all__ = ["check_poses", "render_views"]
