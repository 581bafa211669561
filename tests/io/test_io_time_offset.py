"""``import --time-offset``: a given offset is undone, ``auto`` recovers a known one where the views can tell it and
says so where they cannot."""

from __future__ import annotations

import math

import numpy as np
import pytest

from monovisual3d.errors import InputError
from monovisual3d.io.build import import_session
from monovisual3d.io.detections import ImageDetections
from monovisual3d.io.poses import PoseTrajectory
from monovisual3d.io.time_offset import RAY_CAP_M, estimate_time_offset, ray_misfit
from monovisual3d.sim.motion import frame_times
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import default_camera, random_scene, scene_target
from monovisual3d.sim.simulate import simulate
from monovisual3d.sim.viewpoints import arc_poses

RATE_HZ = 5.0


def _recorded(seed: int, accel: float, box_sigma: float = 0.02, n: int = 6):
    """A session along an arc (its speed growing by ``accel`` per view), its pose stream and its image boxes."""
    rng = np.random.default_rng(seed)
    scene = random_scene(7, rng)
    target = scene_target(scene)

    def path(at):
        at = np.asarray(at, dtype=float)
        return arc_poses(target, n, span=math.radians(60), at=at + accel * at * at)

    frames = frame_times(path, n, RATE_HZ)
    session, _ = simulate(
        scene, default_camera(), path(np.arange(n, dtype=float)), noise=NoiseModel(box_sigma=box_sigma), rng=rng, frames=frames
    )
    images = [ImageDetections(image=f"v{i}.png", stamp=v.stamp, detections=v.detections) for i, v in enumerate(session.views)]
    return session, frames, images


def _stream(frames, offset_s: float) -> PoseTrajectory:
    """The stream running ``offset_s`` ahead of the images (the sample stamped s holds the pose at s + offset)."""
    return PoseTrajectory(frames.stream_T_base_optical, frames.stream_stamps - offset_s, None, "stream")


def test_a_given_time_offset_is_undone():
    session, frames, images = _recorded(0, 0.0)
    r = import_session(session.camera, _stream(frames, 0.1), images, match="stamp", time_offset=0.1)
    for got, want in zip(r.session.views, session.views):
        np.testing.assert_allclose(got.T_base_optical, want.T_base_optical, atol=1e-6)


def test_auto_recovers_a_known_offset_where_the_speed_changes():
    errors = []
    for seed in range(6):
        session, frames, images = _recorded(seed, 0.12)
        r = import_session(session.camera, _stream(frames, 0.1), images, match="stamp", time_offset="auto")
        assert r.summary.time_offset["determined"]
        errors.append(abs(r.summary.time_offset["offset_s"] - 0.1))
    # at 5 Hz a frame is 0.2 s: typically within a quarter frame, never beyond 0.6 of one
    assert np.median(errors) < 0.05 and max(errors) < 0.12, errors
    assert any(n.startswith("time offset: the pose stream runs") for n in r.summary.notes)


def test_auto_says_when_a_constant_speed_path_cannot_tell_it():
    session, frames, images = _recorded(0, 0.0)
    r = import_session(session.camera, _stream(frames, 0.2), images, match="stamp", time_offset="auto")
    assert not r.summary.time_offset["determined"] and r.summary.time_offset["offset_s"] == 0.0
    assert any("not determined" in n and "constant velocity" in n for n in r.summary.notes)


def test_rays_that_meet_have_no_misfit_and_rays_that_miss_are_capped():
    from monovisual3d.frames import look_at

    point = np.array([0.6, 0.0, 0.4])
    T = np.stack([look_at(point + [-0.5, y, 0.0], point) for y in (-0.2, 0.2)])
    rays = [np.linalg.inv(Ti)[:3, :3] @ (point - Ti[:3, 3]) for Ti in T]
    rays = [(r / np.linalg.norm(r))[None] for r in rays]
    assert ray_misfit(T, rays) == pytest.approx(0.0, abs=1e-20)
    far = T.copy()
    far[1, 2, 3] += 1.0  # the second camera a metre higher: its ray passes far from the first's
    assert ray_misfit(far, rays) == pytest.approx(2 * RAY_CAP_M**2)


def test_bad_time_offsets_are_refused_by_name():
    session, frames, images = _recorded(0, 0.0)
    with pytest.raises(InputError, match="--time-offset"):
        import_session(session.camera, _stream(frames, 0.0), images, match="stamp", time_offset="late")
    with pytest.raises(InputError, match="stamps"):
        estimate_time_offset(session.camera, PoseTrajectory(frames.stream_T_base_optical), images)
