"""The extraction (issue 22): its lazy rescoring and, in dense scenes, its lazy split of the search's last level."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d.bench.scale import row_session
from monovisual3d.methods.bayes import extract as extract_module
from monovisual3d.methods.bayes import search as search_module
from monovisual3d.methods.bayes.config import BayesConfig
from monovisual3d.methods.bayes.extract import _extended, extract
from monovisual3d.methods.bayes.hypotheses import last_level
from monovisual3d.methods.bayes.localizer import region_grid
from monovisual3d.methods.bayes.problem import build_problem
from monovisual3d.methods.bayes.search import search


def _search(problem, grid, lazy_last_level):
    """:func:`search` with ``BayesConfig.lazy_last_level`` set."""
    config = replace(problem.config, tuning=replace(problem.config.tuning, lazy_last_level=lazy_last_level))
    return search(replace(problem, config=config), grid)


@pytest.fixture(scope="module")
def dense_row():
    """A row of 24 fruit seen from 4 views (seed 3): its problem and search grid."""
    session, _ = row_session(24, 4, 3)
    problem = build_problem(session.camera, BayesConfig(use_masks=False), session.views)
    return problem, region_grid(problem.config, session.workspace, session.views[0])


@pytest.mark.parametrize("lazy_last_level", [False, True])
def test_lazy_rescoring_takes_the_objects_eager_rescoring_takes(dense_row, lazy_last_level):
    """Rescoring a stale hypothesis only when its bound reaches the look-ahead band is an exact skip (with a lazy
    last level the reference also splits every cell at once)."""
    problem, grid = dense_row
    hyp = _search(problem, grid, lazy_last_level)
    lazy, taken_lazy = extract(problem, hyp)
    eager, taken_eager = extract(problem, hyp, lazy=False)
    assert len(lazy) >= 20 and taken_lazy == taken_eager
    assert [o.score for o in lazy] == [o.score for o in eager]
    assert_array_equal(np.array([o.position for o in lazy]), np.array([o.position for o in eager]))


def test_the_last_level_split_by_the_extraction_takes_the_same_objects_with_less_work(dense_row, monkeypatch):
    """Splitting a cell only when it nears the best gives the objects of the eagerly scored last level, and scores
    fewer hypotheses in all (search, splits and rescoring): the cells of ghost crossings lose their boxes before they
    are split."""
    problem, grid = dense_row
    scored = []
    score = search_module.score_hypotheses

    def counted(problem, taken, centres, radii, cell, mask, *args):
        scored.append(int(mask.sum()))
        return score(problem, taken, centres, radii, cell, mask, *args)

    for module in (search_module, extract_module):
        monkeypatch.setattr(module, "score_hypotheses", counted)
    work, objects, hyps = {}, {}, {}
    for lazy_last_level in (False, True):
        scored.clear()
        hyps[lazy_last_level] = hyp = _search(problem, grid, lazy_last_level)
        objects[lazy_last_level], _ = extract(problem, hyp)
        work[lazy_last_level] = sum(scored)
    eager_hyp, lazy_hyp = hyps[False], hyps[True]
    assert lazy_hyp.child_cell == eager_hyp.cell and lazy_hyp.cell == 2 * eager_hyp.cell
    assert lazy_hyp.children_base is not None and len(lazy_hyp.children_base) == 8 * len(lazy_hyp.centres_base)
    assert eager_hyp.child_cell is None and lazy_hyp.stats()["lazy_last_level"]
    assert len(objects[True]) == len(objects[False]) >= 20
    assert_allclose(np.array([o.position for o in objects[True]]), np.array([o.position for o in objects[False]]), atol=1e-9)
    assert work[True] < 0.9 * work[False]  # 0.84 here; the denser the row, the larger the saving


def test_the_last_level_is_left_to_the_extraction_only_where_it_fits_the_budget(dense_row):
    """A last level over the hypothesis budget is scored by the search in chunks (``capped``), never held whole."""
    problem, grid = dense_row
    small = replace(problem, config=replace(problem.config, tuning=replace(problem.config.tuning, max_hypotheses=5_000)))
    hyp = _search(small, grid, True)
    assert hyp.child_cell is None and hyp.capped and hyp.cell == problem.config.resolution
    assert len(extract(small, hyp)[0]) >= 10


def test_a_search_whose_first_level_is_the_last_scores_it_itself():
    session, _ = row_session(6, 3, 1)
    problem = build_problem(session.camera, BayesConfig(use_masks=False, resolution=0.04), session.views)
    hyp = _search(problem, region_grid(problem.config, session.workspace, session.views[0]), True)
    assert hyp.child_cell is None and hyp.cell == 0.04 and len(extract(problem, hyp)[0]) >= 5


def test_the_last_level_of_no_cells_is_empty(dense_row):
    problem, grid = dense_row
    hyp = _search(problem, grid, True)
    last = last_level(problem, hyp, np.zeros(len(hyp.centres_base), dtype=bool))
    assert last.child_cell is None and last.scores[0].shape == (0, len(hyp.radii)) and len(last.centres_base) == 0
    every = last_level(problem, hyp, np.ones(len(hyp.centres_base), dtype=bool))
    assert every.cell == hyp.child_cell and len(every.centres_base) > len(hyp.centres_base)


@pytest.mark.parametrize("axis", [0, 1])
def test_extended_appends_rows_to_a_buffer_that_doubles(axis):
    buffers: dict = {}
    a = np.zeros((2, 0, 3)) if axis == 1 else np.zeros((0, 3))
    for i in range(40):
        shape = (2, 3, 3) if axis == 1 else (3, 3)
        a = _extended(buffers, "a", a, np.full(shape, float(i)), axis=axis)
    first = a[0, :, 0] if axis == 1 else a[:, 0]
    assert_array_equal(first, np.repeat(np.arange(40.0), 3))
    assert np.shares_memory(a, buffers["a"])  # a view: writes reach the buffer the next append copies from
    assert 120 <= buffers["a"].shape[axis] <= 2 * 120
    first[0] = -1.0  # written through the view, then kept when the buffer grows
    while buffers["a"].shape[axis] < 500:
        a = _extended(buffers, "a", a, np.zeros((2, 3, 3) if axis == 1 else (3, 3)), axis=axis)
    assert (a[0, 0, 0] if axis == 1 else a[0, 0]) == -1.0


def test_the_steal_pass_after_a_lazy_last_level_gives_back_what_the_eager_one_does():
    """A row of 128 fruit (seed 0): the extraction gives one fruit's view-0 box to its neighbour, and only the steal
    pass gives it back, from a last-level hypothesis the lazy extraction never scored: the pass scores the last level
    where a box is free, and finds every fruit as the eager search does (the regroup pass, which runs after an eager
    last level only, off in both)."""
    import monovisual3d as mv
    from monovisual3d.metrics import evaluate

    session, scene = row_session(128, 5, 0)
    positions = {}
    for lazy_last_level in (False, True):
        res = mv.localize(session, use_masks=False, lazy_last_level=lazy_last_level, regroup=False)
        assert res.diagnostics["lazy_last_level"] == lazy_last_level
        positions[lazy_last_level] = res.positions[np.lexsort(res.positions.T)]
        assert evaluate(res.positions, scene.centres, truth_radii=scene.radii).true_positives == 128
    assert_allclose(positions[True], positions[False], atol=1e-9)


def test_lazy_last_level_is_checked():
    from monovisual3d.errors import InputError

    with pytest.raises(InputError, match=r"lazy_last_level: got 'yes', expected true, false or null"):
        BayesConfig.from_options(lazy_last_level="yes")
    assert BayesConfig.from_options(lazy_last_level=None).tuning.lazy_last_level is None
