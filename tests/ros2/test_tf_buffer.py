"""The live TF buffer: interpolation between samples, waiting for TF that arrives after the view, memory bound."""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace as NS

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation, Slerp

from monovisual3d.frames import position_quaternion_from_transform, transform_from_position_quaternion
from monovisual3d.io.tf import TransformUnavailable
from monovisual3d.ros2 import tf_buffer
from monovisual3d.ros2.tf_buffer import LiveTransforms

T0 = 1_800_000_000.0  # a wall-clock time, seconds


def tf_msg(parent: str, child: str, T: np.ndarray, stamp: float) -> NS:
    p, q = position_quaternion_from_transform(T)
    sec, frac = divmod(stamp, 1.0)
    header = NS(frame_id=parent, stamp=NS(sec=int(sec), nanosec=int(round(frac * 1e9))))
    t = NS(translation=NS(x=p[0], y=p[1], z=p[2]), rotation=NS(x=q[0], y=q[1], z=q[2], w=q[3]))
    return NS(transforms=[NS(header=header, child_frame_id=child, transform=t)])


def random_T(rng: np.random.Generator) -> np.ndarray:
    return transform_from_position_quaternion(rng.uniform(-1, 1, 3), Rotation.random(random_state=rng).as_quat())


def test_interpolates_linear_and_slerp_between_samples(rng: np.random.Generator) -> None:
    Ta, Tb, T_tool_cam = random_T(rng), random_T(rng), random_T(rng)
    buf = LiveTransforms()
    buf.add(tf_msg("base", "tool", Ta, T0), static=False)
    buf.add(tf_msg("base", "tool", Tb, T0 + 0.1), static=False)
    buf.add(tf_msg("tool", "cam", T_tool_cam, 0.0), static=True)
    s = 0.3
    expected = np.eye(4)
    expected[:3, 3] = (1 - s) * Ta[:3, 3] + s * Tb[:3, 3]
    expected[:3, :3] = Slerp([0, 1], Rotation.from_matrix([Ta[:3, :3], Tb[:3, :3]]))([s]).as_matrix()[0]
    got = buf.lookup("base", "cam", T0 + s * 0.1, max_gap=0.1, timeout_s=0.0)
    assert_allclose(got, expected @ T_tool_cam, atol=1e-6)  # float stamps near 1.8e9 s: 0.2 us resolution


def test_waits_for_tf_arriving_150_ms_after_the_view(rng: np.random.Generator) -> None:
    """The view at T0 + 0.05 needs the sample at T0 + 0.1 (samples 100 ms apart), which arrives 150 ms later."""
    Ta, Tb = random_T(rng), random_T(rng)
    buf = LiveTransforms()
    buf.add(tf_msg("base", "cam", Ta, T0), static=False)
    assert not buf.available("base", "cam", T0 + 0.05, max_gap=0.1)
    timer = threading.Timer(0.15, lambda: buf.add(tf_msg("base", "cam", Tb, T0 + 0.1), static=False))
    timer.start()
    t = time.monotonic()
    got = buf.lookup("base", "cam", T0 + 0.05, max_gap=0.1, timeout_s=1.0)
    waited = time.monotonic() - t
    timer.join()
    assert waited >= 0.14  # it waited for the late sample rather than holding the first one
    assert_allclose(got[:3, 3], 0.5 * (Ta[:3, 3] + Tb[:3, 3]), atol=1e-6)


def test_times_out_with_the_reason(rng: np.random.Generator) -> None:
    buf = LiveTransforms()
    buf.add(tf_msg("base", "cam", random_T(rng), T0), static=False)
    with pytest.raises(TransformUnavailable, match=r"base -> cam: no sample at or after .* yet"):
        buf.lookup("base", "cam", T0 + 0.05, max_gap=0.1, timeout_s=0.05)
    with pytest.raises(TransformUnavailable, match="camera frame 'nowhere' is not in the transforms"):
        buf.lookup("base", "nowhere", T0, max_gap=0.1, timeout_s=0.0)


def test_bad_transforms_are_reported_not_raised() -> None:
    buf = LiveTransforms()
    T = np.eye(4)
    msg = tf_msg("base", "cam", T, T0)
    msg.transforms[0].transform.rotation.w = 3.0
    assert buf.add(msg, static=False, where="/tf") == ["/tf, transform 0: rotation quaternion norm 3, expected 1"]
    buf.add(tf_msg("base", "cam", T, T0), static=False)
    assert buf.add(tf_msg("other", "cam", T, T0), static=False, where="/tf") == [
        "/tf: frame 'cam' has two parents, 'base' and 'other': not a tree"
    ]


def test_old_samples_are_forgotten(rng: np.random.Generator) -> None:
    buf = LiveTransforms()
    n = int(3 * tf_buffer.CACHE_S / 0.1)
    for k in range(n):
        buf.add(tf_msg("base", "cam", random_T(rng), T0 + 0.1 * k), static=False)
    kept = len(buf._tree._edges["cam"].stamps)
    assert kept <= (tf_buffer.CACHE_S + tf_buffer.PRUNE_EVERY_S) / 0.1 + 2
    with pytest.raises(TransformUnavailable):
        buf.lookup("base", "cam", T0 + 1.0, max_gap=0.1, timeout_s=0.0)
    assert buf.available("base", "cam", T0 + 0.1 * (n - 5), max_gap=0.1)
