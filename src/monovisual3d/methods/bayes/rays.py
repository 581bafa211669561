"""Whether boxes of several views can be one object's: the rays through their centres must meet.

From three or more distinct viewpoints the rays through the centres of one object's boxes meet near a point that
projects near every box's centre (:func:`centres_agree_many`); boxes of different objects rarely do. From two, any two
boxes on one epipolar line pass. :func:`epipolar_trades` screens, for every pair of objects at once, which trades of a
view's boxes the epipolar geometry allows.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .problem import Problem
from .scoring import associations_list
from .state import Found

#: Two objects may trade a view's boxes, wherever they stand, when after the trade the rays through each one's box
#: centres meet at a point that projects within this fraction of each box's half-sizes of its centre: a whole box's
#: centre lies within a few per cent of its object's projection (perspective), and a cut of a fifth of the box moves it
#: by a quarter. With two distinct viewpoints any two boxes on one epipolar line pass; with three or more, only boxes
#: where the object projects.
CENTRE_TOLERANCE = 0.25


#: :func:`epipolar_trades` lets through a box up to this many times the two views' tolerances (:data:`CENTRE_TOLERANCE`
#: of the half-sizes' diagonal, as angles) off the epipolar line: the point of :func:`centres_agree` may lie that far
#: off either ray, seen from a view up to twice as far (a robot's views of one plant differ less; a fuzz of random
#: scenes 0.5-0.7 m away needed at most 1.5 with fy = 0.67 fx, 1.9 at 0.4-1.2 m).
SCREEN_MARGIN = 2.0


#: :func:`centres_agree_many` refuses rays whose normal matrix has a larger condition number: parallel rays (views
#: from one place) fix no point.
MAX_CONDITION = 1e12


#: Two cameras closer than this (metres) stand at one place: no epipolar line (:func:`epipolar_trades`).
SAME_PLACE_M = 1e-9


def centres_agree(problem: Problem, assoc: list[int]) -> bool:
    """Whether the rays through the centres of the boxes ``assoc`` (one per view of ``problem.views``, -1: none) meet
    as one object's do (:func:`centres_agree_many` of one association)."""
    return bool(centres_agree_many(problem, np.asarray(assoc, dtype=np.intp)[None])[0])


def centres_agree_many(problem: Problem, assocs: NDArray[np.intp]) -> NDArray[np.bool_]:
    """Per association (T, V) (a box index per view of ``problem.views``, -1: none; at least two views each), whether
    the rays through its boxes' centres meet as one object's do: their least-squares point lies in front of every
    camera and projects within :data:`CENTRE_TOLERANCE` of each box's half-sizes of its centre, shape (T,)."""
    point, ok, uv, half = _meeting_points(problem, assocs)
    held = assocs >= 0
    R = np.array([vd.T_optical_base[:3, :3] for vd in problem.views]).reshape(-1, 3, 3)
    t = np.array([vd.T_optical_base[:3, 3] for vd in problem.views]).reshape(-1, 3)
    p_optical = np.einsum("kij,tj->tki", R, point) + t[None]  # (T, V, 3)
    in_front = np.all((p_optical[..., 2] > 0) | ~held, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        offset = np.abs(problem.camera.project(p_optical) - uv)
    close = np.all(np.all(offset <= CENTRE_TOLERANCE * half, axis=2) | ~held, axis=1)
    return ok & in_front & close


def meeting_points(problem: Problem, assocs: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Per association (T, V) (a box index per view of ``problem.views``, -1: none), the point (T, 3), metres, base
    frame, closest to the rays through its boxes' centres, and whether the rays fix it (their normal matrix's condition
    number below :data:`MAX_CONDITION`), shape (T,)."""
    return _meeting_points(problem, assocs)[:2]


def _meeting_points(
    problem: Problem, assocs: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`meeting_points`, and the box centres and half-sizes (T, V, 2), pixels (0 and 1 where a view has none)."""
    n, n_views = assocs.shape
    held = assocs >= 0
    uv, half = np.zeros((n, n_views, 2)), np.ones((n, n_views, 2))
    d_base, eyes = np.zeros((n, n_views, 3)), np.zeros((n_views, 3))
    R = np.array([vd.T_optical_base[:3, :3] for vd in problem.views]).reshape(n_views, 3, 3)
    t = np.array([vd.T_optical_base[:3, 3] for vd in problem.views]).reshape(n_views, 3)
    for v, vd in enumerate(problem.views):
        b = vd.boxes[assocs[held[:, v], v]].reshape(-1, 4)
        uv[held[:, v], v], half[held[:, v], v] = 0.5 * (b[:, :2] + b[:, 2:]), 0.5 * (b[:, 2:] - b[:, :2])
        d_base[held[:, v], v] = problem.camera.rays(uv[held[:, v], v]) @ R[v]  # R^T d
        eyes[v] = -R[v].T @ t[v]
    P = (np.eye(3) - d_base[..., :, None] * d_base[..., None, :]) * held[..., None, None]  # projectors across the rays
    A, rhs = P.sum(axis=1), np.einsum("tkij,kj->ti", P, eyes)
    ok = np.all(np.isfinite(A), axis=(1, 2))
    ok[ok] = np.linalg.cond(A[ok]) < MAX_CONDITION
    point = np.zeros((n, 3))
    point[ok] = np.linalg.solve(A[ok], rhs[ok][..., None])[..., 0]
    return point, ok, uv, half


def epipolar_trades(problem: Problem, objects: list[Found]) -> NDArray[np.bool_]:
    """Which trades the epipolar geometry allows, shape (M, M, V): ``[i, k, v]`` where objects ``i`` and ``k`` both
    hold a box in view ``v`` and the centre of ``k``'s box there lies near the epipolar line of ``i``'s box centre in
    each other view ``i`` holds (within :data:`SCREEN_MARGIN` times the two boxes' :data:`CENTRE_TOLERANCE` of their
    half-sizes' diagonal; a camera at the same place as view ``v``'s says nothing), and the other way round: a screen,
    for every pair at once, that lets through the trades :func:`centres_agree` allows (all of them where no view sees
    the point from more than twice another's distance) and few others."""
    assoc = np.array([associations_list(problem, o) for o in objects], dtype=np.intp).reshape(len(objects), len(problem.views))
    n, n_views = assoc.shape
    rays, tol, eyes = np.zeros((n, n_views, 3)), np.zeros((n, n_views)), np.zeros((n_views, 3))
    for v, vd in enumerate(problem.views):
        R, t = vd.T_optical_base[:3, :3], vd.T_optical_base[:3, 3]
        eyes[v] = -R.T @ t
        held = assoc[:, v] >= 0
        b = vd.boxes[assoc[held, v]].reshape(-1, 4)
        rays[held, v] = problem.camera.rays(0.5 * (b[:, :2] + b[:, 2:])) @ R  # base frame
        half = 0.5 * np.hypot(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1])  # the half-sizes' diagonal
        tol[held, v] = CENTRE_TOLERANCE * half / min(problem.camera.fx, problem.camera.fy)
    ok = (assoc[:, None, :] >= 0) & (assoc[None, :, :] >= 0)
    for v in range(n_views):
        for u in range(n_views):
            baseline = eyes[v] - eyes[u]
            if u == v or np.linalg.norm(baseline) < SAME_PLACE_M:
                continue
            normal = np.cross(baseline, rays[:, u])  # (M, 3): the epipolar plane of i's ray in view u
            length = np.linalg.norm(normal, axis=1, keepdims=True)
            normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
            off = np.abs(normal @ rays[:, v].T)  # (M, M): sine of the angle of k's ray in v out of i's plane
            # the point the rays meet may lie off i's ray in u too, as seen from v up to twice as far
            ok[:, :, v] &= (assoc[:, u] < 0)[:, None] | (off <= SCREEN_MARGIN * (tol[None, :, v] + tol[:, u, None]))
    return ok & ok.transpose(1, 0, 2)
