"""The ``bayes`` pipeline's frozen problem data."""

from __future__ import annotations

import numpy as np
import pytest

from monovisual3d.camera import Camera
from monovisual3d.methods.bayes.config import BayesConfig
from monovisual3d.methods.bayes.problem import Problem, ViewData
from monovisual3d.methods.bayes.sensor import SensorModel


def _problem() -> Problem:
    views = tuple(ViewData(i, np.eye(4), np.zeros((n, 4)), (), None) for i, n in enumerate((3, 0, 5)))
    return Problem(Camera.from_hfov(640, 480, 69.0), BayesConfig(), SensorModel(), views)


def test_available_boxes_are_those_not_taken_whatever_holds_the_taken_pairs():
    """A frozenset, a set, a list of lists or an (n, 2) array of ``(v, j)`` pairs give the same answer; the answer of
    the last taken set is shared read-only, and changing the returned list does not change the next answer."""
    problem = _problem()
    want = [[True, False, True], [], [False, True, True, True, False]]
    pairs = [(0, 1), (2, 0), (2, 4)]
    for taken in (frozenset(pairs), set(pairs), [list(p) for p in pairs], np.array(pairs)):
        got = problem.available(taken)
        assert [a.tolist() for a in got] == want
    got = problem.available(frozenset(pairs))
    with pytest.raises(ValueError, match="read-only"):
        got[0][0] = False
    got[0] = np.zeros(3, dtype=bool)
    assert [a.tolist() for a in problem.available(frozenset(pairs))] == want
    assert [a.tolist() for a in problem.available()] == [[True] * 3, [], [True] * 5]


def test_view_at_finds_a_view_by_its_session_index_not_its_position():
    """Views without detections are left out of a problem, so an object's association key (the session's view
    index) is not the view's position in ``problem.views``."""
    views = tuple(ViewData(i, np.eye(4), np.zeros((1, 4)), (), None) for i in (0, 2, 5))
    problem = Problem(Camera.from_hfov(640, 480, 69.0), BayesConfig(), SensorModel(), views)
    assert [problem.view_at(i).index for i in (5, 0, 2)] == [5, 0, 2]
    assert problem.view_at(2) is problem.views[1]
    with pytest.raises(KeyError, match="no view with session index 1"):
        problem.view_at(1)
