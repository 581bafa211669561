"""TransformTree: chaining through the common ancestor, interpolation and the errors."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from monovisual3d.errors import InputError
from monovisual3d.frames import invert_transform
from monovisual3d.io import TransformTree
from monovisual3d.io.tf import TransformUnavailable


def random_T(rng: np.random.Generator) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = rng.uniform(-1, 1, 3)
    return T


def test_lookup_through_a_common_ancestor(rng):
    T_world_base, T_world_a, T_a_cam = random_T(rng), random_T(rng), random_T(rng)
    tree = TransformTree()
    tree.add("/world", "base", T_world_base)
    tree.add("world", "a", T_world_a, stamp=0.0)
    tree.add("world", "a", T_world_a, stamp=1.0)
    tree.add("a", "cam", T_a_cam)
    T = tree.lookup("base", "/cam", 0.5, max_gap=1.0)
    assert_allclose(T, invert_transform(T_world_base) @ T_world_a @ T_a_cam, atol=1e-12)
    assert_allclose(tree.lookup("cam", "base", 0.5, max_gap=1.0) @ T, np.eye(4), atol=1e-12)
    assert tree.frames == {"world", "base", "a", "cam"}


def test_lookup_errors(rng):
    tree = TransformTree()
    tree.add("world", "a", random_T(rng), stamp=0.0)
    tree.add("other", "b", random_T(rng))
    with pytest.raises(TransformUnavailable, match=r"transform world -> a: 2 s after the last pose, more than max_gap 0.1 s"):
        tree.lookup("world", "a", 2.0, max_gap=0.1)
    with pytest.raises(InputError, match="frames 'a' and 'b' are not connected"):
        tree.lookup("a", "b", 0.0, max_gap=0.1)
    with pytest.raises(InputError, match="camera frame 'c' is not in the transforms"):
        tree.lookup("a", "c", 0.0, max_gap=0.1)
    with pytest.raises(InputError, match="frame 'a' has two parents, 'world' and 'other'"):
        tree.add("other", "a", np.eye(4))
    with pytest.raises(InputError, match="a frame cannot be its own parent"):
        tree.add("x", "/x", np.eye(4))


def test_wait_for_later_refuses_to_hold_the_last_sample(rng):
    """Live use: a stamp after the newest sample is not available yet (waited for), where a recording holds the last pose."""
    T0, T1 = random_T(rng), random_T(rng)
    tree = TransformTree()
    tree.add("base", "tool", T0, stamp=10.0)
    tree.add("base", "tool", T1, stamp=10.1)
    assert_allclose(tree.lookup("base", "tool", 10.15, max_gap=0.1), T1, atol=1e-12)
    with pytest.raises(TransformUnavailable, match=r"base -> tool: no sample at or after 10.150 s yet \(latest 10.100 s\)"):
        tree.lookup("base", "tool", 10.15, max_gap=0.1, wait_for_later=True)
    tree.add("base", "tool", T0, stamp=10.2)
    mid = tree.lookup("base", "tool", 10.15, max_gap=0.1, wait_for_later=True)
    assert_allclose(mid, tree.lookup("base", "tool", 10.15, max_gap=0.1), atol=1e-12)
    assert not np.allclose(mid, T1)


def test_forget_before_keeps_lookups_after_the_cut(rng):
    tree = TransformTree()
    poses = [random_T(rng) for _ in range(20)]
    for k, T in enumerate(poses):
        tree.add("base", "tool", T, stamp=0.1 * k)
    tree.add("tool", "cam", random_T(rng))
    queries = np.linspace(0.55, 1.9, 17)
    before = [tree.lookup("base", "cam", t, max_gap=0.1) for t in queries]
    tree.forget_before(0.55)
    assert_allclose([tree.lookup("base", "cam", t, max_gap=0.1) for t in queries], before, atol=1e-12)
    with pytest.raises(TransformUnavailable, match="more than max_gap"):
        tree.lookup("base", "cam", 0.2, max_gap=0.1)
