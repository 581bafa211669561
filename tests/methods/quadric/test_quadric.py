"""The ``quadric`` method (LfD's dual quadric) against identities, exact cases and a slow nonlinear reference."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from monovisual3d import Camera, localize
from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.geometry.ellipsoid import Ellipsoid, bbox_from_dual_conic, dual_quadric
from monovisual3d.geometry.quadric import ellipsoid_from_dual_quadric
from monovisual3d.methods.quadric.config import QuadricConfig
from monovisual3d.methods.quadric.dual import (
    camera_matrix,
    conic_map,
    inscribed_dual_conic,
    solve_dual_quadric,
    unvech4,
    vech,
)
from monovisual3d.session import Detection, Session, View

CAM = Camera(1280, 720, 900.0, 900.0, 640.0, 360.0)
SIZE = (CAM.width, CAM.height)


def _random_sym(rng: np.random.Generator, k: int) -> np.ndarray:
    A = rng.normal(size=(k, k))
    return A + A.T


def test_vech_round_trip_and_conic_map_is_the_projection(rng: np.random.Generator) -> None:
    Q = _random_sym(rng, 4)
    assert_allclose(unvech4(vech(Q)), Q)
    P = rng.normal(size=(3, 4))
    assert_allclose(conic_map(P) @ vech(Q), vech(P @ Q @ P.T), atol=1e-12)


def test_inscribed_ellipse_touches_the_four_box_sides() -> None:
    box = np.array([100.0, 50.0, 180.0, 250.0])
    C = inscribed_dual_conic(box)
    for line in ([1, 0, -100], [1, 0, -180], [0, 1, -50], [0, 1, -250]):  # x = x1, x = x2, y = y1, y = y2
        assert abs(np.array(line) @ C @ np.array(line)) < 1e-9
    assert_allclose(bbox_from_dual_conic(C), box)


def _ring(centre: np.ndarray, rng: np.random.Generator, n: int, distance: float, aim: np.ndarray | None = None) -> np.ndarray:
    """``n`` views spread over 120 degrees around ``centre``, 20-50 degrees above it, looking at ``aim`` (default the centre)."""
    out = []
    for a in np.linspace(0, 2 * np.pi / 3, n) + rng.uniform(0, 2 * np.pi):
        el = rng.uniform(np.radians(20), np.radians(50))
        eye = centre + distance * np.array([np.cos(a) * np.cos(el), np.sin(a) * np.cos(el), np.sin(el)])
        out.append(look_at(eye, centre if aim is None else aim))
    return np.array(out)


def _solve(e: Ellipsoid, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    P = np.stack([camera_matrix(CAM, T) for T in poses])
    boxes = np.stack([e.bbox(CAM, T, clip=False) for T in poses])
    Q, _ = solve_dual_quadric(P, boxes, SIZE)
    return ellipsoid_from_dual_quadric(Q)


@pytest.mark.parametrize("seed", range(6))
def test_exact_when_the_projected_outlines_are_axis_aligned(seed: int) -> None:
    """LfD's inscribed ellipse is the outline when the outline is axis-aligned: an upright spheroid, each camera
    looking at its centre with a level x axis (look_at), so the image is symmetric about its vertical centre line."""
    rng = np.random.default_rng(seed)
    centre = rng.uniform([0.4, -0.2, 0.0], [0.8, 0.2, 0.3])
    e = Ellipsoid.spheroid(centre, rng.uniform(0.02, 0.04), rng.uniform(0.05, 0.1))
    c, s, _ = _solve(e, _ring(centre, rng, int(rng.integers(3, 7)), rng.uniform(0.4, 1.2)))
    assert_allclose(c, centre, atol=1e-7)  # sub-micrometre: the equations hold exactly
    assert_allclose(s, np.sort(e.semi_axes), rtol=1e-5)


def _reference_fit(poses: np.ndarray, boxes: np.ndarray, start: Ellipsoid) -> Ellipsoid:
    """Slow reference: the ellipsoid (centre, log semi-axes, rotation vector) whose projected boxes best match
    ``boxes`` in least squares (pixels), by scipy's trust-region solver from ``start``."""

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return x[:3], np.exp(x[3:6]), Rotation.from_rotvec(x[6:]).as_matrix()

    def residuals(x: np.ndarray) -> np.ndarray:
        c, s, R = unpack(x)
        Q = dual_quadric(c, s, R)
        return (
            np.concatenate([bbox_from_dual_conic(camera_matrix(CAM, T) @ Q @ camera_matrix(CAM, T).T) for T in poses])
            - boxes.ravel()
        )

    x0 = np.concatenate([start.centre_base, np.log(start.semi_axes), Rotation.from_matrix(start.rotation).as_rotvec()])
    x = least_squares(residuals, x0, xtol=1e-14, ftol=1e-14, gtol=1e-14).x
    c, s, R = unpack(x)
    return Ellipsoid.from_rotation(c, s, R)


@pytest.mark.parametrize("seed", range(5))
def test_against_the_slow_box_fit_on_general_ellipsoids(seed: int) -> None:
    """General ellipsoids seen off-centre: the boxes are exact, the inscribed ellipses are not the outlines.

    The slow reference (nonlinear box fit, seeded with LfD's answer) recovers the ellipsoid exactly; LfD's
    closed form lands within a few millimetres of its centre (its modelling error; its semi-axes are off by up
    to about 1 cm, as the inscribed ellipse is larger than a tilted outline).
    """
    rng = np.random.default_rng(100 + seed)
    centre = rng.uniform([0.4, -0.2, 0.0], [0.8, 0.2, 0.3])
    R = Rotation.random(random_state=seed).as_matrix()
    e = Ellipsoid.from_rotation(centre, rng.uniform([0.025, 0.025, 0.05], [0.035, 0.04, 0.07]), R)
    poses = _ring(centre, rng, 4, 0.6, aim=centre + rng.uniform(-0.08, 0.08, 3))
    boxes = np.stack([e.bbox(CAM, T, clip=False) for T in poses])
    c, s, R_hat = _solve(e, poses)
    lfd = Ellipsoid.from_rotation(c, s, R_hat)
    ref = _reference_fit(poses, boxes, lfd)
    assert_allclose(ref.centre_base, centre, atol=1e-6)  # the reference is exact on exact boxes
    assert_allclose(np.sort(ref.semi_axes), np.sort(e.semi_axes), atol=1e-6)
    assert np.linalg.norm(c - ref.centre_base) < 5e-3  # LfD: within 5 mm at 0.6 m for 5-14 cm objects


def test_noisy_boxes_degrade_gracefully_and_the_frame_does_not_matter(rng: np.random.Generator) -> None:
    centre = np.array([0.6, 0.1, 0.2])
    e = Ellipsoid.upright(centre, [0.025, 0.03, 0.06], 0.3)
    poses = _ring(centre, rng, 5, 0.6)
    boxes = np.stack([e.bbox(CAM, T, clip=False) for T in poses]) + rng.normal(0, 1.0, (5, 4))
    P = np.stack([camera_matrix(CAM, T) for T in poses])
    c, _, _ = ellipsoid_from_dual_quadric(solve_dual_quadric(P, boxes, SIZE)[0])
    assert np.linalg.norm(c - centre) < 3e-3  # 1 px box noise at 0.6 m: millimetres
    shift = np.eye(4)
    shift[:3, 3] = [40.0, -25.0, 7.0]  # the same scene in a base frame 48 m away
    P2 = np.stack([camera_matrix(CAM, shift @ T) for T in poses])
    c2, _, _ = ellipsoid_from_dual_quadric(solve_dual_quadric(P2, boxes, SIZE)[0])
    assert_allclose(c2 - shift[:3, 3], c, atol=1e-9)  # preconditioning on the camera centres: frame-invariant


def test_fewer_than_three_views_are_refused() -> None:
    with pytest.raises(InputError, match="at least 3"):
        solve_dual_quadric(np.zeros((2, 3, 4)), np.zeros((2, 4)), SIZE)


# ---------------------------------------------------------------------- the method
def _session(objects: list[Ellipsoid], poses: np.ndarray, tracks: bool, seen: dict[int, int] | None = None) -> Session:
    """A session of exact boxes; ``seen`` maps an object to the number of first views that see it (default all)."""
    seen = seen or {}
    views = []
    for f, T in enumerate(poses):
        dets = [
            Detection(e.bbox(CAM, T), track=j if tracks else None) for j, e in enumerate(objects) if f < seen.get(j, len(poses))
        ]
        views.append(View(T, tuple(sorted(dets, key=lambda d: d.bbox_xyxy[0]))))
    return Session(CAM, tuple(views))


def _two_objects(rng: np.random.Generator) -> tuple[list[Ellipsoid], np.ndarray]:
    objs = [Ellipsoid.spheroid([0.6, -0.08, 0.1], 0.03, 0.06), Ellipsoid.spheroid([0.6, 0.08, 0.1], 0.03, 0.06)]
    return objs, _ring(np.array([0.6, 0.0, 0.1]), rng, 4, 0.7)


def test_method_with_track_ids(rng: np.random.Generator) -> None:
    objs, poses = _two_objects(rng)
    res = localize(_session(objs, poses, tracks=True), method="quadric")
    assert res.diagnostics["association"] == "tracks" and res.warnings == []
    assert [o.extra["track"] for o in res.objects] == [0, 1]
    for o, e in zip(res.objects, objs):
        assert np.linalg.norm(o.position - e.centre_base) < 2e-3
        assert o.score == 4 and len(o.associations) == 4 and o.semi_axes is not None


def test_method_with_the_bayes_association(rng: np.random.Generator) -> None:
    objs, poses = _two_objects(rng)
    res = localize(_session(objs, poses, tracks=False), method="quadric", size_range="0.02,0.1")
    assert res.diagnostics["association"] == "bayes" and len(res.objects) == 2
    err = np.linalg.norm(res.positions[:, None] - np.array([e.centre_base for e in objs])[None], axis=-1).min(axis=1)
    assert np.all(err < 2e-3)


def test_objects_seen_in_too_few_views_are_left_out_with_a_warning(rng: np.random.Generator) -> None:
    objs, poses = _two_objects(rng)
    session = _session(objs, poses, tracks=True, seen={1: 2})  # track 1 only in views 0 and 1
    with pytest.warns(UserWarning, match=r"track 1: boxes in 2 view\(s\), at least min_views=3"):
        res = localize(session, method="quadric")
    assert [o.extra["track"] for o in res.objects] == [0] and res.diagnostics["left_out"] == 1


def test_options_are_checked() -> None:
    for bad, pattern in [
        ({"association": "x"}, "association"),
        ({"min_views": 2}, "min_views"),
        ({"backend": "torch"}, "backend"),
        ({"size_range": "1"}, "size_range"),
    ]:
        with pytest.raises(InputError, match=pattern):
            QuadricConfig(**bad)
    rng = np.random.default_rng(0)
    objs, poses = _two_objects(rng)
    with pytest.raises(InputError, match="association: got 'tracks', but no detection has a track id"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            localize(_session(objs, poses, tracks=False), method="quadric", association="tracks")
