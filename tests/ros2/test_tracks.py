"""Track ids: the same fruit keeps its id from one estimate to the next, whatever the order of the objects."""

from __future__ import annotations

import numpy as np
import pytest

from monovisual3d.ros2.tracks import TRACK_GATE_M, TrackTable, match_tracks


def test_ids_follow_the_fruit_through_a_shuffle_and_small_moves(rng: np.random.Generator) -> None:
    table = TrackTable()
    p = rng.uniform(-0.3, 0.3, (8, 3)) + np.arange(8)[:, None] * [0.1, 0, 0]  # fruit >= 10 cm apart
    ids = table.update(p)
    assert ids.tolist() == list(range(8))
    order = rng.permutation(8)
    moved = p[order] + rng.normal(0, 0.003, (8, 3))
    assert table.update(moved).tolist() == order.tolist()


def test_new_fruit_get_new_ids_and_lost_ones_are_not_reused() -> None:
    table = TrackTable()
    table.update([[0, 0, 0], [0.2, 0, 0]])
    ids = table.update([[0.2, 0.001, 0], [0.5, 0, 0]])
    assert ids.tolist() == [1, 2]
    assert table.update([[0, 0, 0]]).tolist() == [3]  # id 0 was lost: never reused


def test_a_move_beyond_the_gate_is_a_new_fruit() -> None:
    ids = match_tracks([4], [[0, 0, 0]], [[TRACK_GATE_M * 1.5, 0, 0]])
    assert ids.tolist() == [-1]
    assert match_tracks([4], [[0, 0, 0]], [[TRACK_GATE_M * 0.5, 0, 0]]).tolist() == [4]


def test_empty_estimates() -> None:
    assert match_tracks([], np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)
    assert TrackTable().update(np.zeros((0, 3))).shape == (0,)
    with pytest.raises(ValueError, match="2 ids for 1 positions"):
        match_tracks([1, 2], [[0, 0, 0]], [[0, 0, 0]])
