"""Candidate files: pose frames, round trips, validation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.active.candidates import check_candidates, load_candidates, pose_to_dict
from monovisual3d.errors import InputError
from monovisual3d.frames import T_base_optical_from_T_base_cameralink, look_at


@pytest.mark.parametrize("frame", ["optical", "camera_link"])
def test_candidate_file_round_trip(tmp_path: Path, frame: str) -> None:
    T = np.stack([look_at([0.1, 0.2, 0.4], [0.6, 0.0, 0.45]), look_at([0.2, -0.2, 0.6], [0.6, 0.0, 0.45])])
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"pose_frame": frame, "poses": [pose_to_dict(t, frame) for t in T]}))
    assert_allclose(load_candidates(path), T, atol=1e-12)


def test_camera_link_pose_is_converted_with_the_fixed_rotation(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"poses": [{"position": [0.1, 0.0, 0.4], "quaternion_xyzw": [0, 0, 0, 1]}]}))
    T_cl = np.eye(4)
    T_cl[:3, 3] = [0.1, 0.0, 0.4]
    assert_allclose(load_candidates(path, "camera_link")[0], T_base_optical_from_T_base_cameralink(T_cl))
    assert_allclose(load_candidates(path)[0][:3, 2], [0, 0, 1])  # optical: identity looks along base z


def test_bad_candidate_files(tmp_path: Path) -> None:
    p = tmp_path / "c.json"
    p.write_text(json.dumps({"poses": []}))
    with pytest.raises(InputError, match=r"c.json: poses: empty list"):
        load_candidates(p)
    p.write_text(json.dumps({"poses": [{"position": [0, 0, 0], "quaternion_xyzw": [0, 0, 0, 2]}]}))
    with pytest.raises(InputError, match=r"c.json: poses\[0\].quaternion_xyzw: norm 2, expected 1"):
        load_candidates(p)
    p.write_text(json.dumps({"views": []}))
    with pytest.raises(InputError, match="poses: missing field"):
        load_candidates(p)
    p.write_text(json.dumps({"pose_frame": "world", "poses": [{"matrix": np.eye(4).tolist()}]}))
    with pytest.raises(InputError, match="pose_frame: got 'world'"):
        load_candidates(p)
    with pytest.raises(InputError, match=r"expected shape \(N, 4, 4\)"):
        check_candidates(np.eye(3))
