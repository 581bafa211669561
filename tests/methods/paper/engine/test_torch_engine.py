"""The torch backend against the numpy reference: on CPU always (when torch is installed), on CUDA when present."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from conftest import make_camera, paper_cube, scene_views
from monovisual3d.methods.paper.config import PaperConfig
from monovisual3d.methods.paper.filter import HistogramFilter, paper_update, paper_view_likelihood_grid

torch = pytest.importorskip("torch")
from monovisual3d.methods.paper.engine.torch_backend import (  # noqa: E402
    TorchDenseHistogram,
    paper_likelihood_torch,
    paper_update_torch,
    resolve_device,
)

DEVICES = ["cpu", pytest.param("cuda", marks=pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device"))]


def reference_chain(grid, camera, views, kernel):
    p = np.full(grid.n_cells, 1.0 / grid.n_cells)
    for v in views:
        p = paper_update(p, paper_view_likelihood_grid(grid, camera, v, kernel, 0.5))
    return p


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("kernel", ["square", "gaussian"])
@pytest.mark.parametrize("name", ["none", "rational", "equidistant"])
def test_float64_matches_reference(device, kernel, name):
    cam = make_camera(name)
    views = scene_views(cam)
    grid = paper_cube(views, 20)
    lik = paper_likelihood_torch(grid, cam, views[0], kernel, device=device)
    assert lik.device.type == device and tuple(lik.shape) == (grid.n_cells,)
    assert_allclose(lik.cpu().numpy(), paper_view_likelihood_grid(grid, cam, views[0], kernel, 0.5), rtol=1e-12, atol=1e-12)
    p = np.full(grid.n_cells, 1.0 / grid.n_cells)
    for v in views:
        p = paper_update_torch(p, grid, cam, v, kernel, device=device, dtype=torch.float64)
    ref = reference_chain(grid, cam, views, kernel)
    assert_allclose(p, ref, rtol=1e-9, atol=1e-10 * ref.max())


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("kernel", ["square", "gaussian"])
def test_float32_state_and_batch(device, kernel, camera):
    views = scene_views(camera, n_views=4)
    grid = paper_cube(views, 24)
    ref = reference_chain(grid, camera, views, kernel)
    seq = TorchDenseHistogram(grid, kernel=kernel, device=device)
    for v in views:
        assert seq.update_views(camera, v) == [True]
    one = TorchDenseHistogram(grid, kernel=kernel, device=device)
    assert one.update_views(camera, views) == [True] * 4
    for h in (seq, one):
        post = h.posterior().cpu().numpy().ravel()
        assert post.dtype == np.float32
        # float32 geometry: cells within ~1e-4 px of a square box edge may flip; none does in this scene
        assert_allclose(post, ref, rtol=5e-5, atol=1e-6 * ref.max())
    assert seq.memory_bytes == 4 * grid.n_cells


def test_filter_backend_torch(camera):
    views = scene_views(camera)
    grid = paper_cube(views, 16)
    f = HistogramFilter(camera, PaperConfig(kernel="gaussian", backend="torch", device="cpu"), grid=grid)
    for v in views:
        assert f.update(v)
    ref = reference_chain(grid, camera, views, "gaussian")
    assert_allclose(f.posterior.ravel(), ref, rtol=5e-5, atol=1e-6 * ref.max())


def test_device_resolution():
    assert resolve_device("cpu").type == "cpu"
    assert resolve_device(None).type == ("cuda" if torch.cuda.is_available() else "cpu")
    if not torch.cuda.is_available():
        with pytest.raises(ValueError, match="no CUDA device"):
            resolve_device("cuda")
