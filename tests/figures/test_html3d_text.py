"""User text in the 3D view is shown as text: labels, image names and the session's file name cannot add links or styles."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("plotly")
from html3d_cases import two_fruit_session  # noqa: E402

from monovisual3d.figures.html3d import figure_json_from_html, plain_text, write_scene_html  # noqa: E402

LINK = '<a href="https://x">click</a>'
BIG = '<span style="font-size:300px">big</span>'


def hostile_session(tmp_path: Path) -> Path:
    data = two_fruit_session()
    for i, view in enumerate(data["views"]):
        view["image"] = f"{BIG} & view {i}.png"
        for d in view["detections"]:
            d["label"] = LINK
    path = tmp_path / "<b>s&n.json"  # a file name with markup in it
    path.write_text(json.dumps(data))
    return path


def all_strings(value: object) -> list[str]:
    """Every string inside a JSON value."""
    if isinstance(value, str):
        return [value]
    if isinstance(value, dict):
        return [s for v in value.values() for s in all_strings(v)]
    if isinstance(value, list):
        return [s for v in value for s in all_strings(v)]
    return []


def test_labels_image_names_and_file_name_are_escaped(tmp_path: Path) -> None:
    page = write_scene_html(hostile_session(tmp_path), path=tmp_path / "scene.html")
    text = page.read_text()
    fig = figure_json_from_html(text)
    strings = all_strings(fig)
    joined = "\n".join(strings)
    for raw in (LINK, BIG, "<b>s&n.json"):
        assert raw not in joined and raw not in text  # nowhere as markup, neither in the figure nor in the page
        assert plain_text(raw) in joined  # but shown, as text
    assert "&lt;b&gt;s&amp;n.json: 3 views" in fig["layout"]["title"]["text"]
    boxes = [t for t in fig["data"] if t["meta"]["kind"] == "boxes"]
    assert all(f"label {plain_text(LINK)}" in h for t in boxes for h in t["hovertext"])
    frusta = [t for t in fig["data"] if t["meta"]["kind"] == "frustum"]
    assert all(f"({plain_text(BIG)} &amp; view {t['meta']['view']}.png)" in t["hovertext"] for t in frusta)


def test_plain_text_escapes_the_three_characters_plotly_reads_as_markup() -> None:
    assert plain_text("a < b > c & d") == "a &lt; b &gt; c &amp; d"
    assert plain_text("&lt;") == "&amp;lt;"  # an entity in user text stays as typed
    assert plain_text(7) == "7"
