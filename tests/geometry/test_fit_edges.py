"""Tests of the box edges a shape fit uses (``geometry.fit_edges``)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.errors import InputError
from monovisual3d.geometry.fit_edges import EDGE_NOISE_FACTOR, edge_noise_px, hidden_edges, one_sided_edges, usable_edges
from monovisual3d.sim.scenes import default_camera
from monovisual3d.sim.viewpoints import paper_poses

CAM = default_camera()
BOXES = np.array([[100.0, 120.0, 160.0, 200.0], [0.0, 50.0, 40.0, 479.0], [300.0, 200.0, 330.0, 260.0]])


def test_one_sided_edges_keep_a_prediction_inside_the_edge_only() -> None:
    """Residuals are predicted minus observed: inside a low edge (x1, y1) is positive, inside a high edge negative."""
    r = np.array([[1.5, -1.5, 1.5, -1.5], [-0.5, 0.5, -0.5, 0.5]])
    assert_allclose(one_sided_edges(r, np.arange(4)), [[1.5, 0.0, 0.0, -1.5], [0.0, 0.5, -0.5, 0.0]])


def test_one_sided_edges_cost_a_prediction_past_the_limit() -> None:
    """With limits (how far each edge may be hidden), a prediction between the observed edge and its limit costs
    nothing, one past the limit costs from it, one inside the edge as before; a NaN limit is no limit."""
    r = np.array([[1.5, -3.0, 3.0, 0.5], [-0.5, -0.5, 0.5, 0.5]])  # predicted minus observed
    r_limit = np.array([[2.5, -2.0, 2.0, -1.0], [1.0, np.nan, -1.0, np.nan]])  # predicted minus limit (past the edge)
    expected = [[1.5, -2.0, 2.0, 0.0], [0.0, 0.0, 0.0, 0.0]]
    assert_allclose(one_sided_edges(r, np.arange(4), r_limit), expected)
    assert_allclose(one_sided_edges(r, np.arange(4), np.full(r.shape, np.nan)), one_sided_edges(r, np.arange(4)))


def test_hidden_edges_are_the_border_ones_and_the_censored() -> None:
    """Edges on the image border and censored ones bound the object from inside only; without flags, the border ones."""
    censored = np.zeros(BOXES.shape, dtype=bool)
    censored[0, 3] = censored[1, 0] = True  # box 1's x1 lies on the left border anyway
    h = hidden_edges(CAM, BOXES, 1.0, censored)
    assert h.tolist() == [[False, False, False, True], [True, False, False, True], [False] * 4]
    assert hidden_edges(CAM, BOXES, 1.0, None).tolist() == [[False] * 4, [True, False, False, True], [False] * 4]


def test_usable_edges_leave_out_the_border_and_the_censored() -> None:
    """Used edges: finite, off the border, not censored; their noise grows with the box side; too few is refused."""
    poses = paper_poses()
    censored = np.zeros(BOXES.shape, dtype=bool)
    censored[2, 2] = True
    _, _, used, sigma = usable_edges(CAM, poses, BOXES, ("x", "y", "z", "log_r"), "sphere", 0.05, 1.0, 1.0, censored)
    assert used.tolist() == [[True] * 4, [False, True, True, False], [True, True, False, True]]
    assert_allclose(sigma, edge_noise_px(BOXES, 0.05, 1.0)[used])
    assert_allclose(edge_noise_px(BOXES[:1], 0.05, 0.0), [[60, 80, 60, 80]] * np.array(0.05 * EDGE_NOISE_FACTOR))
    with pytest.raises(InputError, match=r"^boxes_xyxy: 2 usable box edges"):
        usable_edges(CAM, poses[:1], BOXES[1:2], ("x", "y", "z", "log_r"), "sphere", 0.05, 1.0, 1.0)
