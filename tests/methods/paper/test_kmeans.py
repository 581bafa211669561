"""From a posterior to objects: k rules, threshold, weighted and geometric centres."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d import InputError, VoxelGrid
from monovisual3d.methods.paper.kmeans import choose_k, kmeans_objects


@pytest.mark.parametrize(
    ("counts", "rule", "k"),
    [
        ([3, 2, 3], "max", 3),
        ([1, 4, 2], "max", 4),
        ([3, 2, 2], "mode", 2),
        ([3, 3, 2, 2], "mode", 3),  # tie: the larger count
        ([3, 2, 4], "min", 2),
        ([3, 2, 4], "last", 4),
        ([3, 2, 0], "last", 2),  # views without detections do not count
        ([0, 2, 0], "min", 2),
        ([3, 2, 3], 5, 5),
        ([3, 2, 3], np.int64(2), 2),
        ([], "max", 0),
        ([0, 0], "mode", 0),
    ],
)
def test_choose_k(counts: list[int], rule: str | int, k: int) -> None:
    assert choose_k(counts, rule) == k


@pytest.mark.parametrize(
    ("rule", "match"),
    [
        ("median", r"^k: got 'median', expected a positive integer or one of \['max', 'mode', 'min', 'last'\]"),
        (0, r"^k: got 0, expected a positive number of objects"),
        (-2, r"^k: got -2"),
        (True, r"^k: got True"),
        ("3", r"^k: got '3'"),
    ],
)
def test_choose_k_rejects_bad_rules(rule: object, match: str) -> None:
    with pytest.raises(InputError, match=match):
        choose_k([1, 2], rule)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=match):
        choose_k([], rule)  # type: ignore[arg-type]  # even with nothing to count


def two_blob_posterior(rng: np.random.Generator) -> tuple[VoxelGrid, np.ndarray, list[np.ndarray]]:
    """A 20x10x10 grid of 1 cm cells with two separated blobs of random, skewed weights."""
    grid = VoxelGrid.from_bounds([0.0, 0.0, 0.0], [0.2, 0.1, 0.1], 0.01)
    p = np.zeros(grid.shape)
    blobs = [(slice(2, 6), slice(2, 5), slice(3, 7)), (slice(13, 18), slice(4, 8), slice(1, 4))]
    for b in blobs:
        p[b] = rng.uniform(0.2, 1.0, p[b].shape)
    p[0, 0, 0] = 0.01  # a stray cell below the keep threshold
    p /= p.sum()
    masks = []
    for b in blobs:
        m = np.zeros(grid.shape, bool)
        m[b] = True
        masks.append(m.ravel())
    return grid, p, masks


def test_weighted_centre_is_sum_wx_over_sum_w(rng: np.random.Generator) -> None:
    grid, p, masks = two_blob_posterior(rng)
    objs = kmeans_objects(grid, p, 2, centre="weighted", keep_threshold=0.1)
    x, w = grid.centres_base(), p.ravel()
    expected = [(w[m, None] * x[m]).sum(0) / w[m].sum() for m in masks]
    got = sorted((o.position for o in objs), key=lambda c: c[0])
    assert_allclose(got, expected, rtol=0, atol=1e-12)
    # not the paper's printed formula sum(w x) / N, nor the plain mean
    assert not np.allclose(got[0], (w[masks[0], None] * x[masks[0]]).sum(0) / masks[0].sum())
    assert not np.allclose(got[0], x[masks[0]].mean(0), atol=1e-5)


def test_geometric_centre_is_the_plain_mean(rng: np.random.Generator) -> None:
    grid, p, masks = two_blob_posterior(rng)
    objs = kmeans_objects(grid, p, 2, centre="geometric", keep_threshold=0.1)
    x = grid.centres_base()
    got = sorted((o.position for o in objs), key=lambda c: c[0])
    assert_allclose(got, [x[m].mean(0) for m in masks], atol=1e-9)


def test_scores_cells_and_covariance(rng: np.random.Generator) -> None:
    grid, p, masks = two_blob_posterior(rng)
    objs = kmeans_objects(grid, p, 2)
    w = p.ravel()
    assert objs[0].score >= objs[1].score  # sorted by decreasing score
    by_x = sorted(objs, key=lambda o: o.position[0])
    for o, m in zip(by_x, masks):
        assert o.score == pytest.approx(w[m].sum(), rel=1e-12)
        assert o.n_cells == m.sum()
        d = grid.centres_base()[m] - o.position
        assert_allclose(o.covariance, (w[m, None, None] * d[:, :, None] * d[:, None, :]).sum(0) / w[m].sum(), atol=1e-15)
    assert sum(o.score for o in objs) == pytest.approx(1 - p[0, 0, 0], rel=1e-12)  # the stray cell is not kept


def test_keep_threshold_selects_cells(rng: np.random.Generator) -> None:
    grid, p, masks = two_blob_posterior(rng)
    flat = p.ravel()
    for thr in (0.1, 0.5, 0.9):
        objs = kmeans_objects(grid, p, 2, keep_threshold=thr)
        assert sum(o.n_cells for o in objs) == np.count_nonzero(flat >= thr * flat.max())


def test_k_is_capped_by_surviving_cells_and_zero_gives_nothing() -> None:
    grid = VoxelGrid.from_bounds([0, 0, 0], [0.05, 0.05, 0.05], 0.01)
    p = np.zeros(grid.n_cells)
    p[[3, 77]] = 0.5
    objs = kmeans_objects(grid, p, 5)
    assert len(objs) == 2
    assert_allclose(sorted(o.score for o in objs), [0.5, 0.5])
    assert kmeans_objects(grid, p, 0) == []
    assert kmeans_objects(grid, np.zeros(grid.n_cells), 3) == []


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"centre": "median"}, r"^centre: got 'median', expected one of \['weighted', 'geometric'\]"),
        ({"keep_threshold": 0.0}, r"^keep_threshold: got 0\.0, expected a value in \(0, 1\]"),
        ({"keep_threshold": 1.01}, r"^keep_threshold: got 1\.01"),
    ],
)
def test_kmeans_objects_rejects_bad_options(kwargs: dict[str, object], match: str) -> None:
    grid = VoxelGrid.from_bounds([0, 0, 0], [0.02, 0.02, 0.02], 0.01)
    with pytest.raises(InputError, match=match):
        kmeans_objects(grid, np.full(8, 1 / 8), 1, **kwargs)  # type: ignore[arg-type]
