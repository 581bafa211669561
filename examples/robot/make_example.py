"""Regenerate ``examples/robot/``: one simulated tomato truss written in the formats a real robot set-up gives.

Run from the repository root (it rewrites the folder it lives in)::

    python examples/robot/make_example.py

Files written (all consistent: 640x480 everywhere, one pose per image, one label file per image):

- ``camera.yaml``: OpenCV FileStorage calibration (``cv2.FileStorage`` / ``calibrateCamera`` output style);
- ``poses.csv``: one row per image, ``image,stamp,x,y,z,qx,qy,qz,qw``: ``T_base_optical`` in metres,
  quaternion ``(x, y, z, w)`` (the camera's optical frame, so no hand-eye file is needed);
- ``labels/img_NNN.txt``: YOLO label files (``class cx cy w h conf``, normalised), ``labels/classes.txt``;
- ``images/img_NNN.png``: what the camera saw (the simulator's label image, 640x480);
- ``truth.json``: the simulated fruit, for ``monovisual3d evaluate``.

Import it with the command of ``docs/robot.md`` (a test runs that exact line)::

    monovisual3d import --camera examples/robot/camera.yaml --poses examples/robot/poses.csv \
        --detections examples/robot/labels --output session.json
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from monovisual3d.camera import Camera
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import greenhouse_scene, scene_target
from monovisual3d.sim.simulate import SimulatedView, simulate_views, view_image, write_png
from monovisual3d.sim.viewpoints import poses_by_name

HERE = Path(__file__).resolve().parent
#: Seed of the truss and of the detector noise.
SEED = 3
#: The camera: 640x480 with the paper's 69 degree horizontal field of view.
WIDTH, HEIGHT, HFOV_DEG = 640, 480, 69.0
#: Viewpoints: a ring of this many poses around the truss, this many degrees apart, at this distance (m).
N_VIEWS, RING_DEG, DISTANCE_M = 4, 30.0, 0.5
#: Detector noise: box edges scatter by this fraction of the box size (a good detector), no missed fruit.
BOX_SIGMA = 0.02
#: Stamp of the first image (seconds) and the time between images.
T0_S, DT_S = 1_700_000_000.0, 2.0
#: Confidences written in the label files: uniform in this range.
CONF_RANGE = (0.70, 0.97)


def opencv_yaml(camera: Camera) -> str:
    """The camera as OpenCV FileStorage YAML (``%YAML:1.0``, ``!!opencv-matrix``), as ``cv2.FileStorage`` writes it."""
    k = ", ".join(f"{v:.10g}" for v in camera.opencv_matrix().ravel())
    return (
        "%YAML:1.0\n---\n"
        f"image_width: {camera.width}\nimage_height: {camera.height}\n"
        f"camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {k} ]\n"
        "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n"
    )


def pose_row(name: str, stamp: float, T_base_optical: np.ndarray) -> str:
    """One ``poses.csv`` row: image, stamp, position (m) and quaternion (x, y, z, w) of ``T_base_optical``."""
    x, y, z = np.round(T_base_optical[:3, 3], 6) + 0.0  # + 0.0: no "-0.000000"
    q = Rotation.from_matrix(T_base_optical[:3, :3]).as_quat()
    return f"{name},{stamp:.2f},{x:.6f},{y:.6f},{z:.6f},{q[0]:.8f},{q[1]:.8f},{q[2]:.8f},{q[3]:.8f}"


def yolo_lines(view: SimulatedView, rng: np.random.Generator) -> list[str]:
    """YOLO label lines (class 0, normalised centre and size, confidence) of the view's boxes."""
    lines = []
    for x1, y1, x2, y2 in view.boxes_xyxy:
        cx, cy, w, h = (x1 + x2) / 2 / WIDTH, (y1 + y2) / 2 / HEIGHT, (x2 - x1) / WIDTH, (y2 - y1) / HEIGHT
        lines.append(f"0 {cx:.6f} {cy:.6f} {w:.6f} {h:.6f} {rng.uniform(*CONF_RANGE):.3f}")
    return lines


def main() -> None:
    rng = np.random.default_rng(SEED)
    camera = Camera.from_hfov(WIDTH, HEIGHT, HFOV_DEG)
    scene = greenhouse_scene(rng, camera=camera)
    poses = poses_by_name(f"ring:{N_VIEWS}:{RING_DEG:g}", scene_target(scene), distance=DISTANCE_M)
    views = simulate_views(scene, camera, poses, noise=NoiseModel(box_sigma=BOX_SIGMA), rng=rng)
    (HERE / "labels").mkdir(exist_ok=True)
    (HERE / "images").mkdir(exist_ok=True)
    (HERE / "camera.yaml").write_text(opencv_yaml(camera))
    rows = ["image,stamp,x,y,z,qx,qy,qz,qw"]
    for i, view in enumerate(views):
        name = f"img_{i:03d}"
        rows.append(pose_row(f"{name}.png", T0_S + DT_S * i, view.T_base_optical_reported))
        (HERE / "labels" / f"{name}.txt").write_text("".join(line + "\n" for line in yolo_lines(view, rng)))
        write_png(HERE / "images" / f"{name}.png", view_image(view, boxes=False))
    (HERE / "poses.csv").write_text("\n".join(rows) + "\n")
    (HERE / "labels" / "classes.txt").write_text("tomato\n")
    (HERE / "truth.json").write_text(json.dumps(scene.truth_dict(), indent=2) + "\n")
    print(f"wrote {len(views)} views of {len(scene.fruits)} fruit to {HERE}")


if __name__ == "__main__":
    main()
