"""Real LfD-layout data: how far each given box lies from the box of its ground-truth ellipsoid, and the centre error
that offset alone implies (first order: the least-squares centre shift that explains the box-edge offsets).

Usage: python experiments/real_box_offsets.py [--data FOLDER]   (default: the shared Aldoma set, as ``bench real``)
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from monovisual3d.bench.real import ALDOMA_RELATIVE, default_folder
from monovisual3d.errors import InputError
from monovisual3d.frames import invert_transform, transform_points
from monovisual3d.geometry.ellipsoid import ellipsoid_bbox_optical
from monovisual3d.io.lfd import read_lfd
from monovisual3d.session import Session

#: Finite-difference step of the box Jacobian, metres.
STEP_M = 1e-4


def box_jacobian(cam, T_optical_base: np.ndarray, c: np.ndarray, ax: np.ndarray, R: np.ndarray) -> np.ndarray:  # noqa: ANN001
    """Derivative (4, 3) of the predicted box edges with respect to the centre (base frame), numerically."""
    pred = ellipsoid_bbox_optical(cam, transform_points(T_optical_base, c[None])[0], ax, T_optical_base[:3, :3] @ R, clip=False)
    J = np.zeros((4, 3))
    for i in range(3):
        dc = np.zeros(3)
        dc[i] = STEP_M
        p = transform_points(T_optical_base, (c + dc)[None])[0]
        J[:, i] = (ellipsoid_bbox_optical(cam, p, ax, T_optical_base[:3, :3] @ R, clip=False) - pred) / STEP_M
    return J


def load(folder: str) -> tuple[Session, dict]:
    """The LfD folder's session and ground truth, with the detections' track ids (the true association)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the clipped box's warning
        return read_lfd(folder, keep_association=True)


def main(s: Session, truth: dict) -> None:
    cam = s.camera
    for k, o in enumerate(truth["objects"]):
        c = np.array(o["position"])
        ax = np.array(o["semi_axes"])
        R = Rotation.from_quat(o["quaternion_xyzw"]).as_matrix()
        rows, offs = [], []
        for v in s.views:
            det = [d for d in v.detections if d.track == k]
            if not det:
                continue
            T = invert_transform(v.T_base_optical)
            p = transform_points(T, c[None])[0]
            pred = ellipsoid_bbox_optical(cam, p, ax, T[:3, :3] @ R, clip=False)
            offs.append(det[0].bbox_xyxy - pred)
            rows.append(box_jacobian(cam, T, c, ax, R))
        # edges off the image border are censored in the method; use them all here (first-order bound)
        d, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(offs), rcond=None)
        offs = np.array(offs)
        print(
            f"object {k}: mean box offset (x1,y1,x2,y2) px {np.round(offs.mean(0), 1)}, centre v offset {np.mean((offs[:, 1] + offs[:, 3]) / 2):.1f} px;"
            f" distance {np.mean([np.linalg.norm(c - v.T_base_optical[:3, 3]) for v in s.views]):.2f} m;"
            f" least-squares centre shift explaining the offsets: {1000 * np.linalg.norm(d):.1f} mm {np.round(1000 * d, 1)}"
        )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--data", default=default_folder(), help=f"folder of LfD arrays (default: the shared Aldoma set, {ALDOMA_RELATIVE})"
    )
    args = parser.parse_args()
    if args.data is None:
        parser.error(f"--data: not given, and the shared Aldoma set is not at {ALDOMA_RELATIVE}; give the folder of LfD arrays")
    try:
        data = load(str(args.data))
    except InputError as exc:
        parser.error(str(exc))
    main(*data)
