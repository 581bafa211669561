"""Frames along a camera path: image stamps, poses a time offset late, the pose stream and its import files."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d.errors import InputError
from monovisual3d.io.build import import_session
from monovisual3d.sim.motion import (
    IMAGE_START_S,
    MAX_OFFSET_FRAMES,
    POSE_RATE_HZ,
    check_timing,
    frame_times,
    write_import_files,
)
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import paper_scene, scene_target
from monovisual3d.sim.simulate import simulate, simulate_views
from monovisual3d.sim.viewpoints import arc_poses, row_poses

N = 5
RATE = 4.0


def arc(at):
    return arc_poses(scene_target(paper_scene()), N, span=np.radians(60.0), at=at)


def test_stamps_are_one_frame_apart_and_reported_poses_follow_the_offset():
    ft = frame_times(arc, N, RATE, 0.0)
    assert_allclose(ft.stamps, IMAGE_START_S + np.arange(N) / RATE)
    assert_allclose(ft.T_base_optical_reported, arc(np.arange(N)), atol=1e-12)
    late = frame_times(arc, N, RATE, 1.0 / RATE)  # one frame late: the next view's pose
    assert_allclose(late.T_base_optical_reported[:-1], arc(np.arange(N))[1:], atol=1e-12)
    early = frame_times(arc, N, RATE, -0.5 / RATE)  # half a frame early: between views
    assert_allclose(early.T_base_optical_reported, arc(np.arange(N) - 0.5), atol=1e-12)


def test_the_stream_covers_the_images_at_the_pose_rate_and_holds_the_path_ahead_by_the_offset():
    offset = 0.3 / RATE
    ft = frame_times(arc, N, RATE, offset)
    assert ft.stream_T_base_optical.shape == (len(ft.stream_stamps), 4, 4)
    assert_allclose(np.diff(ft.stream_stamps), 1.0 / POSE_RATE_HZ, atol=1e-9)
    assert ft.stream_stamps[0] <= ft.stamps[0] - 1.0 / RATE + 1e-9 and ft.stream_stamps[-1] >= ft.stamps[-1] + 1.0 / RATE - 1e-9
    k = 37  # any sample: the path at its stamp plus the offset
    at = (ft.stream_stamps[k] + offset - IMAGE_START_S) * RATE
    assert_allclose(ft.stream_T_base_optical[k], arc(np.array([at]))[0], atol=1e-12)


def test_bad_timing_is_refused_by_name():
    with pytest.raises(InputError, match="--frame-rate"):
        check_timing(0.0, 0.0)
    with pytest.raises(InputError, match=r"--time-offset .*\(10 frames at 4 Hz\)"):
        check_timing((MAX_OFFSET_FRAMES + 1) / RATE, RATE)
    with pytest.raises(InputError, match="n_views"):
        frame_times(arc, 0, RATE)


def test_frames_change_the_reported_poses_and_stamps_not_the_draws():
    """Same seed with and without frames: the same boxes (no new draw), poses from the stream, stamps in the session."""
    scene, P = paper_scene(), arc(np.arange(N))
    noise = NoiseModel(box_sigma=0.05, drop_probability=0.1)
    plain, _ = simulate(scene, poses=P, noise=noise, rng=3)
    ft = frame_times(arc, N, RATE, 1.0 / RATE)
    timed, truth = simulate(scene, poses=P, noise=noise, rng=3, frames=ft)
    for a, b in zip(plain.views, timed.views):
        assert_array_equal(a.boxes_xyxy, b.boxes_xyxy)
    assert_allclose([v.stamp for v in timed.views], ft.stamps)
    assert_allclose(np.stack([v.T_base_optical for v in timed.views]), ft.T_base_optical_reported, atol=1e-12)
    assert truth["frames"]["time_offset_s"] == 1.0 / RATE and len(truth["frames"]["image_stamps"]) == N
    assert all(v.stamp is None for v in plain.views) and "frames" not in _
    with pytest.raises(InputError, match="frames: stamps and poses for 5 views, expected 3"):
        simulate_views(scene, poses=P[:3], frames=ft)


def test_import_rebuilds_the_session_from_the_written_stream(tmp_path):
    """poses.csv + detections.csv through `import --match stamp`: the session's poses (late by the offset) and boxes."""

    def row(at):
        return row_poses(N, scene_target(paper_scene()), length=0.4, distance=0.6, at=at)

    ft = frame_times(row, N, RATE, 0.5 / RATE)
    session, truth = simulate(paper_scene(), poses=row(np.arange(N)), noise=NoiseModel(box_sigma=0.03), rng=1, frames=ft)
    E = NoiseModel.from_mm_deg(hand_eye_error_mm=5.0).hand_eye_error(rng=0)
    paths = write_import_files(tmp_path, session, ft, E)
    imported = import_session(session.camera, paths["poses"], paths["detections"], match="stamp").session
    assert len(imported.views) == N
    for a, b in zip(session.views, imported.views):
        assert_allclose(b.T_base_optical, a.T_base_optical @ E, atol=1e-6)  # linear interpolation in a 100 Hz stream
        assert_allclose(b.boxes_xyxy, a.boxes_xyxy, atol=1e-9)
    with pytest.raises(InputError, match="image stamp"):
        write_import_files(tmp_path, simulate(paper_scene(), rng=0)[0], ft)
