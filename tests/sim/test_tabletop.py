"""The table-top scene of lying boxes and standing bottles: layout, views, boxes inside the images, seeds."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d.errors import InputError
from monovisual3d.frames import check_transform
from monovisual3d.sim.tabletop import (
    BOTTLE_FOOTPRINT_M,
    BOTTLE_HALF_H_M,
    BOX_FOOTPRINT_M,
    BOX_HALF_SIDES_M,
    DISTANCE_M,
    HALF_TABLE_M,
    N_BOTTLES,
    N_LYING,
    N_VIEWS,
    tabletop_camera,
    tabletop_scene,
)


def test_the_objects_stand_apart_on_the_table() -> None:
    table = tabletop_scene(800)
    c = table.centres_base
    assert c.shape == (N_LYING + N_BOTTLES, 3)
    assert np.all(np.abs(c[:, :2]) <= HALF_TABLE_M)
    assert_allclose(c[:N_LYING, 2], BOX_HALF_SIDES_M[2])  # resting on the table, z = 0
    assert_allclose(c[N_LYING:, 2], BOTTLE_HALF_H_M)
    reach = np.array([BOX_FOOTPRINT_M] * N_LYING + [BOTTLE_FOOTPRINT_M] * N_BOTTLES)
    gap = np.linalg.norm(c[:, None, :2] - c[None, :, :2], axis=2) - reach[:, None] - reach[None]
    assert np.all(gap[~np.eye(len(c), dtype=bool)] >= 0)


def test_the_views_look_at_the_table_and_every_box_is_inside_its_image() -> None:
    cam = tabletop_camera()
    table = tabletop_scene(801)
    assert table.T_base_optical.shape == (N_VIEWS, 4, 4) and table.boxes_xyxy.shape == (N_VIEWS, N_LYING + N_BOTTLES, 4)
    for T in table.T_base_optical:
        check_transform(T)
    distance = np.linalg.norm(table.T_base_optical[:, :3, 3], axis=1)
    assert np.all((distance >= DISTANCE_M[0]) & (distance <= DISTANCE_M[1]))
    assert np.all(table.T_base_optical[:, 0, 3] < 0)  # on the table's -x side
    B = table.boxes_xyxy
    assert np.all(B[..., :2] >= 0) and np.all(B[..., 2] <= cam.width) and np.all(B[..., 3] <= cam.height)
    assert np.all(B[..., 2:] > B[..., :2])


def test_given_azimuths_and_cuboids() -> None:
    table = tabletop_scene(5, azimuths_deg=[-30.0, -27.0, 60.0])
    offset = table.T_base_optical[:, :3, 3]
    assert_allclose(np.degrees(np.arctan2(offset[:, 1], -offset[:, 0])), [-30.0, -27.0, 60.0], atol=1e-9)
    ellipsoids, cuboids = tabletop_scene(810), tabletop_scene(810, cuboids=True)
    assert_array_equal(cuboids.centres_base, ellipsoids.centres_base)  # the same draws
    outer, inner = cuboids.boxes_xyxy[:, :N_LYING], ellipsoids.boxes_xyxy[:, :N_LYING]
    assert np.all(outer[..., :2] <= inner[..., :2] + 1e-9) and np.all(outer[..., 2:] >= inner[..., 2:] - 1e-9)
    assert_array_equal(cuboids.boxes_xyxy[:, N_LYING:], ellipsoids.boxes_xyxy[:, N_LYING:])  # the same bottles


def test_seeded() -> None:
    a, b = tabletop_scene(np.random.default_rng(3)), tabletop_scene(3)
    assert_array_equal(a.boxes_xyxy, b.boxes_xyxy)
    assert not np.array_equal(tabletop_scene(4).centres_base, a.centres_base)


def test_bad_azimuths() -> None:
    with pytest.raises(InputError, match="azimuths_deg: got shape"):
        tabletop_scene(0, azimuths_deg=[[0.0, 1.0]])
