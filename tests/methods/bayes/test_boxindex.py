"""The tile index of the ``bayes`` kernels (issue 22): it skips only boxes outside the gate, so scores are the scan's."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d.camera import Camera
from monovisual3d.errors import InputError
from monovisual3d.frames import look_at, transform_points
from monovisual3d.geometry.sphere import predict_sphere_boxes
from monovisual3d.methods.bayes._kernels import score_hypotheses
from monovisual3d.methods.bayes.boxindex import MIN_TILE_PX, build_index, candidate_boxes, tile_px
from monovisual3d.methods.bayes.likelihood import box_scores, view_scores
from monovisual3d.methods.bayes.sensor import SensorModel, cell_shift_px, gate_widening_px

CAM = Camera.from_hfov(1280, 720, 90.0)
TARGET = np.array([0.6, 0.0, 0.45])


def _dense_views(rng, n_boxes=300):
    """Three row-like views with many boxes: overlapping, tiny and huge, duplicated, and cut by the border."""
    poses = [look_at(TARGET + [-0.8, y, 0.0], TARGET + [0.0, y, 0.0]) for y in (0.3, 0.0, -0.3)]
    views = []
    for _ in poses:
        c = rng.uniform([-50, -50], [1330, 770], (n_boxes, 2))
        half = rng.uniform(2, 90, (n_boxes, 2)) * rng.choice([1.0, 3.0], (n_boxes, 1))
        b = np.clip(np.hstack([c - half, c + half]), 0, [1280, 720, 1280, 720])
        b = b[(b[:, 2] > b[:, 0]) & (b[:, 3] > b[:, 1])]
        b = np.vstack([b, b[:5], [[0, 100, 60, 160], [1230, 0, 1280, 40]]])  # exact duplicates (ties) and border boxes
        views.append(b)
    return [np.linalg.inv(T) for T in poses], views


def _reference(T_ob, boxes, avail, centres, radii, model, blur):
    total = np.zeros((len(centres), len(radii)))
    n_assoc = np.zeros(total.shape, dtype=np.int32)
    assoc = []
    for T, b, a in zip(T_ob, boxes, avail):
        p_opt = transform_points(T, centres)
        pred, vis = predict_sphere_boxes(CAM, p_opt, radii)
        extra = max(CAM.fx, CAM.fy) * blur / np.maximum(p_opt[:, 2:3], 1e-6)
        gate = gate_widening_px(model, pred, 0.0, cell_shift_px(CAM, pred, p_opt[:, 2:3], blur))
        llr, a_ref = view_scores(pred, vis, b, a, model, CAM.width, CAM.height, extra, gate)
        total += llr
        n_assoc += a_ref >= 0
        assoc.append(a_ref)
    return total, n_assoc, np.array(assoc)


MODELS = {
    "default": SensorModel(),
    "low floors": SensorModel(inward_floor=1.0, outward_floor=2.0),
    "strict": SensorModel(alpha=0.02, sigma0_px=0.5, inward_floor=5.0, outward_floor=9.0, match_bonus=12.0, p_miss=0.3),
    "wide gate": SensorModel(gate_sigmas=20.0),
    "no gate margin": SensorModel(gate_sigmas=0.0),
}


@pytest.mark.parametrize("name", list(MODELS))
@pytest.mark.parametrize("blur", [0.0, 0.01, 0.04])
def test_indexed_kernel_equals_the_scan_over_all_boxes(name, blur):
    model = MODELS[name]
    rng = np.random.default_rng(22)
    T_ob, boxes = _dense_views(rng)
    avail = [rng.random(len(b)) > 0.2 for b in boxes]
    centres = TARGET + rng.uniform([-0.2, -0.7, -0.4], [0.2, 0.7, 0.4], (400, 3))
    radii = np.geomspace(0.01, 0.08, 6)
    total, n_assoc, assoc = score_hypotheses(CAM, T_ob, boxes, avail, centres, radii, model, blur)
    ref_total, ref_n, ref_assoc = _reference(T_ob, boxes, avail, centres, radii, model, blur)
    assert_array_equal(assoc, ref_assoc)
    assert_array_equal(n_assoc, ref_n)
    assert_allclose(total, ref_total, rtol=1e-9, atol=1e-9)
    assert np.count_nonzero(ref_assoc >= 0) > 100  # the case has matches to get right


def test_every_box_inside_the_gate_is_a_candidate_once():
    """The numpy twin of the compiled look-up: each box meeting the query rectangle is listed exactly once, the boxes
    left out all lie outside the gate, and most boxes are never looked at."""
    model = SensorModel()
    rng = np.random.default_rng(5)
    T_ob, boxes = _dense_views(rng, n_boxes=150)
    index = build_index(boxes, CAM.width, CAM.height)
    centres = TARGET + rng.uniform([-0.2, -0.7, -0.4], [0.2, 0.7, 0.4], (150, 3))
    radii = np.geomspace(0.01, 0.08, 4)
    n_left_out = n_pairs = 0
    for v, (T, b) in enumerate(zip(T_ob, boxes)):
        pred, vis = predict_sphere_boxes(CAM, transform_points(T, centres), radii)
        for i, k in zip(*np.nonzero(vis)):
            p = pred[i, k]
            sx, sy = (model.alpha * (p[2] - p[0]) + model.sigma0_px, model.alpha * (p[3] - p[1]) + model.sigma0_px)
            g = model.gate_sigmas
            query = np.array([p[0] - g * sx, p[1] - g * sy, p[2] + g * sx, p[3] + g * sy])
            cand = candidate_boxes(index, v, query)
            assert len(np.unique(cand)) == len(cand)
            meets = (b[:, 0] <= query[2]) & (b[:, 2] >= query[0]) & (b[:, 1] <= query[3]) & (b[:, 3] >= query[1])
            assert set(np.flatnonzero(meets)) <= set(cand.tolist())
            out = np.setdiff1d(np.arange(len(b)), cand)
            assert np.all(np.isneginf([box_scores(p, b[j], model, CAM.width, CAM.height) for j in out]))
            n_left_out += len(out)
            n_pairs += len(b)
    assert n_left_out > 0.6 * n_pairs  # most boxes are never looked at


def test_gate_rejects_a_box_beside_the_prediction_and_keeps_an_occluded_one():
    model = SensorModel()
    pred = np.array([100.0, 100.0, 200.0, 200.0])
    sigma = model.alpha * 100 + model.sigma0_px  # 6 px
    beside = np.array([200.0 + 3 * sigma + 1, 100.0, 300.0, 200.0])  # wholly right of the widened prediction
    touching = np.array([200.0 + 3 * sigma - 1, 100.0, 300.0, 200.0])
    occluded = np.array([100.0, 150.0, 200.0, 200.0])  # the lower half of the silhouette
    assert box_scores(pred, beside, model, 640, 480) == -np.inf
    assert np.isfinite(box_scores(pred, touching, model, 640, 480))
    assert box_scores(pred, occluded, model, 640, 480) > model.miss_term
    # a box on the image border beside the prediction's far side is still judged by its other edges
    assert box_scores(np.array([-50.0, 100, 50, 200]), np.array([0.0, 100, 48, 200]), model, 640, 480) > model.miss_term


def test_tile_size_and_bad_gate():
    assert tile_px(np.zeros((0, 4)), 640, 480) == MIN_TILE_PX
    assert tile_px(np.array([[0.0, 0, 4, 4]]), 6400, 480) == 100.0  # at most 64 tiles across
    with pytest.raises(InputError, match="gate_sigmas: got -1"):
        SensorModel(gate_sigmas=-1)


def test_views_without_boxes_and_all_boxes_taken():
    rng = np.random.default_rng(1)
    T_ob, boxes = _dense_views(rng, n_boxes=20)
    boxes[1] = np.zeros((0, 4))
    avail = [np.ones(len(b), bool) for b in boxes]
    avail[2][:] = False
    centres = TARGET + rng.uniform(-0.2, 0.2, (50, 3))
    radii = np.array([0.02, 0.04])
    got = score_hypotheses(CAM, T_ob, boxes, avail, centres, radii, SensorModel(), 0.01)
    ref = _reference(T_ob, boxes, avail, centres, radii, SensorModel(), 0.01)
    assert_array_equal(got[2], ref[2])
    assert_allclose(got[0], ref[0], rtol=1e-9, atol=1e-9)
    index = build_index(boxes, CAM.width, CAM.height)
    assert index.count[1] == 0 and len(candidate_boxes(index, 1, np.array([0.0, 0, 1280, 720]))) == 0


def test_extraction_picks_the_hypothesis_a_full_argmax_picks():
    """The extraction's per-row bests (kept up to date row by row) find what argmax over all hypotheses finds."""
    from monovisual3d.methods.bayes.extract import _Work

    rng = np.random.default_rng(7)
    total = np.round(rng.normal(size=(300, 5)), 1)  # rounded: many ties, the first one wins as in np.argmax
    total[rng.random(total.shape) < 0.3] = -np.inf
    n_assoc = rng.integers(0, 4, total.shape).astype(np.int32)
    work = _Work.from_scores(total, n_assoc, np.zeros((2, 300, 5), np.int16), 2)
    for _ in range(20):
        rows = rng.random(300) > 0.3
        c, k, s = work.best(rows)
        full = np.where(rows[:, None] & work.active[:, None] & (work.n_assoc >= 2), work.total, -np.inf)
        assert (c, k) == np.unravel_index(int(np.argmax(full)), full.shape) and s == full.max()
        every = np.where(work.active[:, None] & (work.n_assoc >= 2), work.total, -np.inf)  # best(): every active row
        c, k, s = work.best()
        if np.isfinite(every.max()):
            assert (c, k) == np.unravel_index(int(np.argmax(every)), every.shape) and s == every.max()
        work.suppress(rng.random(300) < 0.05)
        changed = np.flatnonzero(rng.random(300) < 0.1)
        work.total[changed] = rng.normal(size=(len(changed), 5))
        work.update(changed, 2)


def test_rows_using_a_box_are_those_a_scan_finds():
    """The extraction's box index (the starting associations, then those of the rows rescored or appended, in merged
    runs) finds exactly the rows whose current association holds a box, as a scan over all rows does; most
    hypotheses hold no box (the index looks only at those that hold one)."""
    from monovisual3d.methods.bayes.extract import _Work

    rng = np.random.default_rng(11)

    def scored(m):  # associations (3, m, 6), most -1, and the views each hypothesis holds a box in
        a = np.where(rng.random((3, m, 6)) < 0.3, rng.integers(0, 15, (3, m, 6)), -1).astype(np.int16)
        return a, (a >= 0).sum(axis=0).astype(np.int32)

    assoc, n_assoc = scored(400)
    work = _Work.from_scores(rng.normal(size=(400, 6)), n_assoc, assoc, 2)
    for step in range(40):
        n = len(work.total)
        if step % 4 == 3:  # new rows (a cell's children)
            new, n_new = scored(int(rng.integers(1, 30)))
            work.append(rng.normal(size=n_new.shape), n_new, new, 2)
        else:  # rows rescored: their boxes change
            changed = np.flatnonzero(rng.random(n) < rng.choice([0.01, 0.1]))
            new, n_new = scored(len(changed))
            work.rescore(changed, rng.normal(size=(len(changed), 6)), n_new, new, 2)
        rows, v, boxes = rng.random(len(work.total)) < 0.7, int(rng.integers(3)), rng.choice(15, 2, replace=False)
        scan = np.flatnonzero(rows & np.isin(work.assoc[v], boxes).any(axis=1))
        assert_array_equal(work.using(v, boxes, rows), scan)
    assert len(work.total) > 400 and len(work.users[0].runs) < 10  # rows appended; runs merged as they grow


def test_too_many_boxes_in_a_view_are_refused_before_any_work():
    from types import SimpleNamespace

    from monovisual3d.errors import InputError
    from monovisual3d.limits import MAX_BAYES_BOXES_PER_VIEW
    from monovisual3d.methods.bayes.pipeline import check_work

    views = [SimpleNamespace(boxes=np.zeros((n, 4)), index=i) for i, n in enumerate([3, MAX_BAYES_BOXES_PER_VIEW + 1])]
    with pytest.raises(InputError, match=r"views\[1\]\.detections: .*limits\.MAX_BAYES_BOXES_PER_VIEW"):
        check_work(SimpleNamespace(views=views))
    check_work(SimpleNamespace(views=views[:1]))


def test_too_many_views_are_refused_before_any_work():
    from types import SimpleNamespace

    from monovisual3d.errors import InputError
    from monovisual3d.limits import MAX_BAYES_VIEWS
    from monovisual3d.methods.bayes.pipeline import check_work

    views = [SimpleNamespace(boxes=np.zeros((2, 4)), index=i) for i in range(MAX_BAYES_VIEWS + 1)]
    with pytest.raises(InputError, match=rf"views: {MAX_BAYES_VIEWS + 1} views with boxes, .*limits\.MAX_BAYES_VIEWS"):
        check_work(SimpleNamespace(views=views))
    check_work(SimpleNamespace(views=views[:MAX_BAYES_VIEWS]))


def test_extraction_cells_near_a_point_are_those_a_scan_finds():
    """The extraction's look-up of the cells near a point (a slab of the longest axis, then the second) finds exactly
    the cells a test of every centre finds, on a grid (ties at the radius) and off it."""
    from monovisual3d.methods.bayes.extract import _Cells

    rng = np.random.default_rng(3)
    centres = (np.floor(rng.uniform(0, 1, (5000, 3)) * [120, 25, 70]) + 0.5) * 0.01  # 1 cm cells of a row
    cells = _Cells.of(centres)
    for _ in range(300):
        point = centres[rng.integers(len(centres))] + rng.normal(0, 0.01, 3) * rng.integers(0, 2)
        radius = float(rng.choice([0.01, 0.02, 0.05, np.sqrt(3) * 0.01]))
        found = cells.within(point, radius)
        assert len(np.unique(found)) == len(found)
        assert np.array_equal(np.sort(found), np.flatnonzero(np.linalg.norm(centres - point, axis=1) <= radius))
    assert len(cells.within(np.array([np.nan, 0.0, 0.0]), 0.1)) == 0
    assert len(_Cells.of(np.zeros((0, 3))).within(np.zeros(3), 0.1)) == 0
