"""A view of very many boxes: linear cost, a bounded page that says it thinned what it drew, never a traceback."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("plotly")
from html3d_cases import two_fruit_session  # noqa: E402

from monovisual3d import load_session  # noqa: E402
from monovisual3d.errors import InputWarning  # noqa: E402
from monovisual3d.figures.html3d import MAX_DRAWN_BOXES, figure_json_from_html, select_boxes, write_scene_html  # noqa: E402

#: Boxes per view: the most a session may hold (limits.MAX_DETECTIONS_PER_VIEW), in each of three views.
N_BOXES = 2_000
N_VIEWS = 3
#: The page holds plotly.js (about 4.6 MB) and at most MAX_DRAWN_BOXES boxes, cones and menu entries.
MAX_PAGE_BYTES = 20_000_000


def many_boxes_session(n: int = N_BOXES, views: int = 1) -> dict[str, Any]:
    """``views`` views of one camera, each with ``n`` seeded random boxes inside the 640 x 480 image."""
    rng = np.random.default_rng(7)
    data = two_fruit_session()
    data["views"] = data["views"][:views]
    for view in data["views"]:
        x1y1 = rng.uniform([0, 0], [600, 440], size=(n, 2))
        boxes = np.column_stack([x1y1, x1y1 + rng.uniform(5, 40, size=(n, 2))])
        view["detections"] = [{"bbox_xyxy": b.tolist(), "score": 0.5, "label": "tomato"} for b in boxes]
    return data


@pytest.fixture(scope="module")
def big_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("big") / "session.json"
    path.write_text(json.dumps(many_boxes_session(N_BOXES, N_VIEWS)))
    return path


def test_six_thousand_boxes_give_a_bounded_page_that_says_it_thinned(big_session: Path, tmp_path: Path) -> None:
    with pytest.warns(InputWarning, match=r"session\.json: view: drew 2,000 of 6,000 boxes"):
        page = write_scene_html(big_session, path=tmp_path / "scene.html")
    assert page.stat().st_size < MAX_PAGE_BYTES
    fig = figure_json_from_html(page.read_text())
    notes = [a["text"] for a in fig["layout"]["annotations"]]
    assert any("drew 2,000 of 6,000 boxes" in n for n in notes)  # the page says so too
    assert len(fig["layout"]["updatemenus"][0]["buttons"]) == 1 + MAX_DRAWN_BOXES
    boxes = [t for t in fig["data"] if t["meta"]["kind"] == "boxes"]
    assert sum(v is None for t in boxes for v in t["x"]) == MAX_DRAWN_BOXES  # one None after each drawn outline
    cones = [t for t in fig["data"] if t["meta"]["kind"] == "cones"]
    assert sum(t["meta"]["count"] for t in cones) == MAX_DRAWN_BOXES


def test_the_view_command_warns_on_the_console_and_exits_0(big_session: Path, tmp_path: Path) -> None:
    out = tmp_path / "scene.html"
    cmd = [sys.executable, "-m", "monovisual3d.cli", "view", str(big_session), "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    warning = [line for line in proc.stderr.splitlines() if line.startswith("warning:")]
    assert len(warning) == 1 and "drew 2,000 of 6,000 boxes" in warning[0]
    assert out.stat().st_size < MAX_PAGE_BYTES


def test_the_page_grows_linearly_below_the_cap(tmp_path: Path) -> None:
    """Twice the boxes, at most about twice the figure (the cone menu once grew with the square of the boxes)."""
    sizes = []
    for n in (250, 500, 1000):
        fig = figure_json_from_html(write_scene_html(many_boxes_session(n), path=tmp_path / f"s{n}.html").read_text())
        sizes.append(len(json.dumps(fig)))
    assert sizes[2] / sizes[1] < 2.2 and sizes[1] / sizes[0] < 2.2


def test_thinning_is_deterministic_and_spread_over_the_views() -> None:
    session = load_session(many_boxes_session(n=1500, views=2))
    a, b = select_boxes(session), select_boxes(session)
    assert a.total == 3000 and a.drawn == MAX_DRAWN_BOXES and a.thinned
    assert all(np.array_equal(x, y) for x, y in zip(a.per_view, b.per_view))
    assert [len(d) for d in a.per_view] == [1000, 1000]  # in proportion to each view's boxes
    assert a.per_view[0][0] == 0 and a.per_view[1][-1] == 1499  # the first and the last box are drawn
    small = select_boxes(load_session(two_fruit_session()))
    assert not small.thinned and small.note() == ""
