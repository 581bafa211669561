"""Fixtures of the ``bayes`` tests."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.frames import transform_points
from monovisual3d.methods.bayes.likelihood import view_scores
from monovisual3d.methods.bayes.sensor import cell_shift_px, gate_widening_px


def _check_against_reference(cam, T_ob, boxes, avail, centres, predict, model, blur, got) -> np.ndarray:
    """Assert the kernel's ``got = (total, n_assoc, assoc)`` equals the sum over views of
    :func:`~monovisual3d.methods.bayes.likelihood.view_scores` (the numpy reference) for boxes predicted by
    ``predict(p_optical, T_optical_base) -> (pred, visible)``; returns the reference's associated views (N, K)."""
    total, n_assoc, assoc = got
    ref_total, ref_n = np.zeros_like(total), np.zeros_like(n_assoc)
    for v, (T, b, a) in enumerate(zip(T_ob, boxes, avail)):
        p_opt = transform_points(T, centres)
        pred, vis = predict(p_opt, T)
        extra = max(cam.fx, cam.fy) * blur / np.maximum(p_opt[:, 2:3], 1e-6)
        gate = gate_widening_px(model, pred, 0.0, cell_shift_px(cam, pred, p_opt[:, 2:3], blur))
        llr, a_ref = view_scores(pred, vis, b, a, model, cam.width, cam.height, extra, gate)
        ref_total += llr
        ref_n += a_ref >= 0
        assert_allclose(assoc[v], a_ref)
    assert_allclose(total, ref_total, rtol=1e-9, atol=1e-9)
    assert_allclose(n_assoc, ref_n)
    return ref_n


@pytest.fixture
def kernel_reference() -> Callable[..., np.ndarray]:
    """The check of a compiled score kernel against the numpy reference (see ``_check_against_reference``)."""
    return _check_against_reference
