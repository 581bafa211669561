"""The fused numba update against the numpy reference (methods/paper/kernels.py and filter.py).

Tolerances (see monovisual3d.methods.paper.engine.dense):
- float64: the likelihood to 1e-12 absolute (the Gaussian cut-off drops terms below
  gauss_eps = 1e-12) and rounding; posteriors to rtol 1e-9 + 1e-10 of the maximum (per
  view the cut-off moves a cell by at most gauss_eps / max(L) <= N * gauss_eps of the maximum);
- float32 (the default): posteriors to rtol 2e-5 + 1e-6 of the maximum.
"""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from conftest import make_camera, paper_cube, scene_views
from monovisual3d.errors import InputError
from monovisual3d.grid import VoxelGrid
from monovisual3d.methods.paper.config import PaperConfig
from monovisual3d.methods.paper.engine.dense import (
    DenseHistogram,
    DenseHistogramBatch,
    numba_kernels,
    paper_likelihood_fused,
    paper_update_fused,
)
from monovisual3d.methods.paper.filter import HistogramFilter, paper_update, paper_view_likelihood_grid
from monovisual3d.session import Detection, View

KERNELS = ("square", "gaussian")


def reference_chain(grid, camera, views, kernel, sigma_fraction=0.5):
    p = np.full(grid.n_cells, 1.0 / grid.n_cells)
    out = []
    for v in views:
        p = paper_update(p, paper_view_likelihood_grid(grid, camera, v, kernel, sigma_fraction))
        out.append(p)
    return out


@pytest.mark.parametrize("kernel", KERNELS)
def test_likelihood_matches_reference(kernel, distortion):
    cam = make_camera(distortion)
    views = scene_views(cam)
    grid = paper_cube(views, 24)
    for v in views:
        ref = paper_view_likelihood_grid(grid, cam, v, kernel, 0.5)
        fast = paper_likelihood_fused(grid, cam, v, kernel, 0.5)
        assert fast.shape == (grid.n_cells,) and fast.dtype == np.float64
        assert_allclose(fast, ref, rtol=1e-12, atol=1e-12)
        assert np.count_nonzero(ref >= ref.max() / 2) > 10  # cells inside the boxes are exercised


@pytest.mark.parametrize("kernel", KERNELS)
def test_update_matches_reference_float64_and_float32(kernel, distortion):
    cam = make_camera(distortion)
    views = scene_views(cam)
    grid = paper_cube(views, 20)
    refs = reference_chain(grid, cam, views, kernel)
    p64 = np.full(grid.n_cells, 1.0 / grid.n_cells)
    p32 = p64.astype(np.float32)
    for v, ref in zip(views, refs):
        p64 = paper_update_fused(p64, grid, cam, v, kernel, dtype=np.float64)
        p32 = paper_update_fused(p32, grid, cam, v, kernel)
        assert p32.dtype == np.float32
        assert_allclose(p64, ref, rtol=1e-9, atol=1e-10 * ref.max())
        assert_allclose(p32, ref, rtol=2e-5, atol=1e-6 * ref.max())
        assert p64.sum() == pytest.approx(1.0, abs=1e-12)


def test_update_leaves_the_prior_untouched(camera, views):
    grid = paper_cube(views, 16)
    prior = np.full(grid.n_cells, 1.0 / grid.n_cells)
    keep = prior.copy()
    paper_update_fused(prior, grid, camera, views[0], "gaussian", dtype=np.float64)
    assert np.array_equal(prior, keep)


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("log_space", [False, True])
def test_state_matches_reference(kernel, log_space, camera, views):
    grid = paper_cube(views, 20)
    refs = reference_chain(grid, camera, views, kernel)
    h = DenseHistogram(grid, kernel=kernel, log_space=log_space, dtype=np.float64)
    for v, ref in zip(views, refs):
        assert h.update_views(camera, v) == [True]
        assert_allclose(h.posterior().ravel(), ref, rtol=1e-9, atol=1e-10 * ref.max())
    assert h.posterior().shape == grid.shape
    lp = h.log_posterior().ravel()
    big = refs[-1] > 1e-6 * refs[-1].max()  # below that the Gaussian cut-off may have zeroed a cell
    assert_allclose(lp[big], np.log(refs[-1][big]), atol=1e-8)
    assert np.all(np.isneginf(lp[refs[-1] == 0]))


@pytest.mark.parametrize("kernel", KERNELS)
def test_batch_of_views_equals_sequential(kernel, camera):
    views = scene_views(camera, n_views=5)
    grid = paper_cube(views, 20)
    seq = DenseHistogram(grid, kernel=kernel)
    for v in views:
        seq.update_views(camera, v)
    one = DenseHistogram(grid, kernel=kernel)
    assert one.update_views(camera, views) == [True] * 5
    ref = reference_chain(grid, camera, views, kernel)[-1]
    assert_allclose(one.posterior().ravel(), seq.posterior().ravel(), rtol=1e-5, atol=1e-7 * ref.max())
    assert_allclose(one.posterior().ravel(), ref, rtol=2e-5, atol=1e-6 * ref.max())


def test_many_grids_in_one_call_equal_separate_runs(camera):
    """Batching sessions: three grids (different poses, shapes, cameras, views) in one kernel call."""
    cams = [make_camera("none"), make_camera("plumb_bob"), make_camera("equidistant")]
    sessions = [scene_views(c, n_views=n) for c, n in zip(cams, (3, 2, 4))]
    grids = [
        paper_cube(sessions[0], 16),
        paper_cube(sessions[1], 20),
        VoxelGrid.from_bounds([0.4, -0.3, 0.2], [0.9, 0.3, 0.7], 0.025),
    ]
    kinds = ["square", "gaussian"]
    for kernel in kinds:
        batch = DenseHistogramBatch(grids, kernel=kernel, dtype=np.float64)
        assert batch.update(cams, sessions) == [[True] * len(s) for s in sessions]
        for s, (g, c, vs) in enumerate(zip(grids, cams, sessions)):
            ref = reference_chain(g, c, vs, kernel)[-1]
            assert_allclose(batch.posterior(s).ravel(), ref, rtol=1e-9, atol=1e-10 * ref.max())
    assert batch.memory_bytes >= 8 * sum(g.n_cells for g in grids)


def test_contradicting_view_is_skipped_like_the_filter(camera, views):
    grid = paper_cube(views, 16)
    far = View(views[0].T_base_optical, (Detection(np.array([0.0, 0.0, 4.0, 4.0])),))  # a corner the fruit never reach
    h = DenseHistogram(grid, kernel="square", dtype=np.float64)
    used = h.update_views(camera, [views[0], far, views[1]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = HistogramFilter(camera, PaperConfig(kernel="square", backend="numpy"), grid=grid)
        flags = [f.update(v) for v in (views[0], far, views[1])]
    assert used == flags == [True, False, True]
    assert_allclose(h.posterior().ravel(), f.posterior.ravel(), rtol=1e-9, atol=1e-15)
    assert h.update_views(camera, View(views[0].T_base_optical)) == [False]  # no detections


def test_filter_backend_numba_matches_numpy(camera, views):
    grid = paper_cube(views, 20)
    out = {}
    for backend in ("numpy", "numba"):
        f = HistogramFilter(camera, PaperConfig(kernel="gaussian", backend=backend), grid=grid)
        for v in views:
            assert f.update(v)
        out[backend] = f
    a, b = out["numpy"].posterior, out["numba"].posterior
    assert b.dtype == np.float32 and b.shape == grid.shape
    assert_allclose(b, a, rtol=2e-5, atol=1e-6 * a.max())
    ea, eb = out["numpy"].estimate(), out["numba"].estimate()
    assert len(ea) == len(eb) == 6
    assert_allclose(np.array([o.position for o in eb]), np.array([o.position for o in ea]), atol=1e-4)
    lik = paper_view_likelihood_grid(grid, camera, views[0], "square", 0.5, backend="numba")
    assert_allclose(lik, paper_view_likelihood_grid(grid, camera, views[0], "square", 0.5))


def test_config_validates_backend_options():
    with pytest.raises(InputError, match="backend"):
        PaperConfig(backend="cupy")
    with pytest.raises(InputError, match="device"):
        PaperConfig(backend="numba", device="cuda")
    with pytest.raises(InputError, match="refine_to"):
        PaperConfig(resolution=0.01, refine_to=0.02)
    with pytest.raises(InputError, match="refine_to"):
        PaperConfig(refine_to=-1.0)


def test_bad_input_is_rejected(camera, views):
    grid = paper_cube(views, 8)
    with pytest.raises(InputError, match="prior"):
        paper_update_fused(np.ones(7), grid, camera, views[0])
    with pytest.raises(InputError, match="dtype"):
        DenseHistogram(grid, dtype=np.int32)
    with pytest.raises(InputError, match="at least one box"):
        paper_likelihood_fused(grid, camera, View(views[0].T_base_optical), "square")
    with pytest.raises(InputError, match="views_per_grid"):
        DenseHistogramBatch([grid, grid]).update(camera, [[views[0]]])


def test_missing_numba_names_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "numba", None)
    with pytest.raises(ImportError, match="pip install"):
        numba_kernels()
