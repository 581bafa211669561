"""Voxel grids: bounds, the paper's cube in front of the camera, the memory guard."""

from __future__ import annotations

import re

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d import InputError, VoxelGrid
from monovisual3d.frames import invert_transform, look_at, transform_points
from monovisual3d.grid import BYTES_PER_CELL, check_grid_size


def test_from_bounds_covers_the_box() -> None:
    g = VoxelGrid.from_bounds([0.2, -0.3, 0.0], [1.0, 0.3, 0.45], 0.1)
    assert g.shape == (8, 6, 5)  # 0.45 / 0.1 rounds up to cover the box
    assert g.n_cells == 240
    assert_allclose(g.size_m, [0.8, 0.6, 0.5])
    c = g.centres_base()
    assert c.shape == (240, 3)
    assert_allclose(c.min(axis=0), [0.25, -0.25, 0.05])
    assert_allclose(c.max(axis=0), [0.95, 0.25, 0.45])


def test_exact_multiples_do_not_add_a_cell() -> None:
    """0.3 / 0.1 is 2.9999999999999996 in floating point: still 3 cells."""
    assert VoxelGrid.from_bounds([0, 0, 0], [0.3, 0.3, 0.3], 0.1).shape == (3, 3, 3)


def test_flat_index_is_c_order_over_ijk() -> None:
    g = VoxelGrid.from_bounds([0, 0, 0], [0.3, 0.2, 0.4], 0.1)
    assert g.shape == (3, 2, 4)
    i, j, k = 2, 1, 3
    flat = np.ravel_multi_index((i, j, k), g.shape)
    assert_allclose(g.centres_grid([flat])[0], [0.25, 0.15, 0.35])
    assert_allclose(g.centres_grid()[flat], [0.25, 0.15, 0.35])


def test_in_front_of_camera_is_the_papers_cube(rng: np.random.Generator) -> None:
    """A cube of side 2R, centred on the optical axis, from the camera out to 2R, axes along the optical frame."""
    T_base_optical = look_at(rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3) + [3, 0, 0])
    reach, res = 0.3, 0.02
    g = VoxelGrid.in_front_of_camera(T_base_optical, res, reach)
    assert g.shape == (30, 30, 30)
    assert_allclose(g.T_base_grid[:3, :3], T_base_optical[:3, :3], atol=1e-12)
    p_opt = transform_points(invert_transform(T_base_optical), g.centres_base())
    half = reach - 0.5 * res
    assert_allclose(p_opt.min(axis=0), [-half, -half, 0.5 * res], atol=1e-9)
    assert_allclose(p_opt.max(axis=0), [half, half, 2 * reach - 0.5 * res], atol=1e-9)


def test_in_front_of_camera_stays_centred_when_2r_is_not_a_multiple() -> None:
    """With 2R / resolution not an integer the cube grows by part of a cell, symmetrically about the axis."""
    g = VoxelGrid.in_front_of_camera(np.eye(4), 0.07, 0.3)  # 600 mm / 70 mm = 8.57 -> 9 cells
    assert g.shape == (9, 9, 9)
    c = g.centres_base()
    assert_allclose(c[:, :2].mean(axis=0), [0.0, 0.0], atol=1e-12)
    assert_allclose(c[:, :2].min(axis=0), -c[:, :2].max(axis=0), atol=1e-12)
    assert c[:, 2].min() > 0


def test_to_dict() -> None:
    d = VoxelGrid.from_bounds([0, 0, 0], [0.2, 0.2, 0.2], 0.1).to_dict()
    assert d["shape"] == [2, 2, 2] and d["n_cells"] == 8 and d["resolution_m"] == 0.1
    assert_allclose(d["T_base_grid"], np.eye(4))


@pytest.mark.parametrize("resolution", [0.0, -0.01, float("nan"), float("inf"), "0.01"])
def test_bad_resolution(resolution: object) -> None:
    with pytest.raises(InputError, match=r"^resolution: got .*, expected a positive number of metres"):
        VoxelGrid.from_bounds([0, 0, 0], [1, 1, 1], resolution)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"^resolution: got"):
        VoxelGrid.in_front_of_camera(np.eye(4), resolution)  # type: ignore[arg-type]


@pytest.mark.parametrize("reach", [0.0, -0.6, float("nan")])
def test_bad_reach(reach: float) -> None:
    with pytest.raises(InputError, match=r"^reach: got .*, expected a positive number of metres"):
        VoxelGrid.in_front_of_camera(np.eye(4), 0.01, reach)


def test_grid_too_large_is_refused_with_size_and_a_resolution_that_fits() -> None:
    max_bytes = 1_000_000
    with pytest.raises(InputError) as info:
        VoxelGrid.from_bounds([0, 0, 0], [1.0, 1.0, 1.0], 0.01, max_bytes=max_bytes)
    msg = str(info.value)
    assert msg.startswith("resolution: a 10 mm grid has 1,000,000 cells (100x100x100) and needs about ")
    assert "over the max_memory budget of 976.6 KiB" in msg
    suggested = float(re.search(r"resolution ([0-9.e-]+) m fits", msg).group(1))  # type: ignore[union-attr]
    assert suggested > 0.01
    g = VoxelGrid.from_bounds([0, 0, 0], [1.0, 1.0, 1.0], suggested, max_bytes=max_bytes)  # the suggestion fits
    assert g.n_cells * BYTES_PER_CELL <= max_bytes


def test_check_grid_size_boundary() -> None:
    check_grid_size((10, 10, 10), 0.01, max_bytes=1000 * BYTES_PER_CELL)
    with pytest.raises(InputError, match=r"1,001 cells \(1001x1x1\)"):
        check_grid_size((1001, 1, 1), 0.01, max_bytes=1000 * BYTES_PER_CELL)


def test_paper_cube_is_guarded_too() -> None:
    with pytest.raises(InputError, match=r"^resolution: a 1 mm grid has 1,728,000,000 cells \(1200x1200x1200\)"):
        VoxelGrid.in_front_of_camera(np.eye(4), 0.001, 0.6)
