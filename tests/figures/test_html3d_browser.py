"""The scene HTML in a real browser: headless Chromium loads it without errors and draws the scene.

Chromium (Debian package ``chromium``; ``.ci/run`` installs it when missing) loads a copy of
the page with a small probe script added at the top of ``<head>``: the probe records uncaught
errors and ``console.error`` calls and, once the page has loaded, writes them with the number of
traces plotly drew and the on-screen boxes of the legend, the cone menu and its caption into a
``<pre>`` element that ``--dump-dom`` prints. The same run takes a screenshot at 1400 x 1000 and
1400 x 1800, in which the 3D plot area must show the cameras and the red estimates, and the
scene must not be cut at the window's left edge. No DevTools connection is needed.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("plotly")

from html3d_cases import result_dict, truth_dict, two_fruit_session  # noqa: E402

from monovisual3d.figures._style import CAMERA_COLOUR, ESTIMATE_COLOUR  # noqa: E402
from monovisual3d.figures.html3d import figure_json_from_html, write_scene_html  # noqa: E402

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
BROWSER = next((b for b in BROWSERS if shutil.which(b)), None)
pytestmark = pytest.mark.skipif(
    BROWSER is None, reason="no chromium binary on PATH (Debian: apt-get install chromium; .ci/run installs it)"
)

PROBE = """<script>
window.__mv3dErrors = [];
window.addEventListener("error", function (e) { window.__mv3dErrors.push(String(e.message)); });
(function () {
  var original = console.error;
  console.error = function () { window.__mv3dErrors.push(Array.prototype.join.call(arguments, " ")); return original.apply(console, arguments); };
})();
window.addEventListener("load", function () {
  setTimeout(function () {
    var gd = document.getElementById("mv3d-scene");
    var pre = document.createElement("pre");
    pre.id = "mv3d-probe";
    function box(selector) {
      var e = document.querySelector(selector);
      if (!e) { return null; }
      var r = e.getBoundingClientRect();
      return [r.left, r.top, r.right, r.bottom];
    }
    pre.textContent = JSON.stringify({
      errors: window.__mv3dErrors,
      traces: gd && gd._fullData ? gd._fullData.length : -1,
      legend: box("g.legend"),
      menu: box("g.updatemenu-header-group"),
      caption: box("g.annotation"),
      window: [window.innerWidth, window.innerHeight]
    });
    document.body.appendChild(pre);
  }, 500);
});
</script>"""
#: Window sizes of the screenshots, pixels (width, height): a laptop-like one and a tall one.
SIZES = ((1400, 1000), (1400, 1800))
#: Page background and plotly's 3D panes (the template's grey-blue), RGB.
BACKGROUND = np.array([[255, 255, 255], [229, 236, 246]])
#: The 3D panes start at least this far from the window's left edge, pixels (the page margin is 10 px).
MIN_LEFT_GAP_PX = 40


def run_browser(
    page: Path, tmp: Path, screenshot: Path | None = None, size: tuple[int, int] = SIZES[0]
) -> tuple[dict[str, Any], str]:
    """Load ``page`` with the probe in a ``size`` (width, height) window; returns the probe's report and Chromium's log."""
    probed = tmp / f"probed-{page.name}"
    probed.write_text(page.read_text().replace("<head>", "<head>" + PROBE, 1))
    cmd = [
        str(BROWSER),
        "--headless",
        "--no-sandbox",  # CI runs as root
        "--use-angle=swiftshader",  # software WebGL, the same on machines with and without a GPU
        "--enable-unsafe-swiftshader",
        "--hide-scrollbars",
        "--no-first-run",
        f"--user-data-dir={tmp / 'profile'}",
        f"--window-size={size[0]},{size[1]}",
        "--virtual-time-budget=5000",
        "--enable-logging=stderr",
        "--v=0",
        "--dump-dom",
    ]
    if screenshot is not None:
        cmd.append(f"--screenshot={screenshot}")
    proc = subprocess.run([*cmd, probed.resolve().as_uri()], capture_output=True, text=True, timeout=180)
    m = re.search(r'<pre id="mv3d-probe">(.*?)</pre>', proc.stdout, re.S)
    assert m, f"the probe did not report (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    return json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&")), proc.stderr


def uncaught_console_errors(log: str) -> list[str]:
    """Console lines of Chromium's log that report a JavaScript error."""
    return [line for line in log.splitlines() if ":CONSOLE" in line and ("Uncaught" in line or "Error:" in line)]


def paper_like_result() -> dict[str, Any]:
    """The paper method's kind of result: centres without a size, with wide covariances."""
    objects = [dict(o) for o in result_dict()["objects"]]
    for o in objects:
        for key in ("radius", "semi_axes", "quaternion_xyzw"):
            o.pop(key, None)
        o["covariance"] = np.diag([4e-4, 1e-4, 1e-4]).tolist()
    return {"method": "paper", "objects": objects}


@pytest.fixture(
    scope="module", params=[(r, size) for r in ("bayes", "paper") for size in SIZES], ids=lambda p: f"{p[0]}-{p[1][0]}x{p[1][1]}"
)
def browser_run(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> tuple[Path, dict[str, Any], str, Path, tuple[int, int]]:
    kind, size = request.param
    tmp = tmp_path_factory.mktemp("browser")
    result = result_dict() if kind == "bayes" else paper_like_result()
    page = write_scene_html(two_fruit_session(), result, truth_dict(), path=tmp / "scene.html")
    shot = tmp / "shot.png"
    report, log = run_browser(page, tmp, shot, size)
    return page, report, log, shot, size


def screenshot_rgb(shot: Path, size: tuple[int, int]) -> np.ndarray:
    mpimg = pytest.importorskip("matplotlib.image")
    rgb = (255 * mpimg.imread(shot)[..., :3]).round().astype(int)
    assert rgb.shape[:2] == (size[1], size[0])
    return rgb


def near(rgb: np.ndarray, colour: str | np.ndarray, tol: int = 40) -> np.ndarray:
    """Pixels within ``tol`` (per channel) of ``colour`` (hex or RGB)."""
    c = np.array([int(colour[k : k + 2], 16) for k in (1, 3, 5)]) if isinstance(colour, str) else colour
    return np.abs(rgb - c).max(axis=-1) < tol


def test_page_loads_without_errors(browser_run: tuple[Path, dict[str, Any], str, Path, tuple[int, int]]) -> None:
    page, report, log, _, _ = browser_run
    assert report["errors"] == []
    assert uncaught_console_errors(log) == []
    assert report["traces"] == len(figure_json_from_html(page.read_text())["data"])  # plotly drew every trace


def test_screenshot_shows_the_scene(browser_run: tuple[Path, dict[str, Any], str, Path, tuple[int, int]]) -> None:
    _, _, _, shot, size = browser_run
    rgb = screenshot_rgb(shot, size)
    width, height = size
    plot = rgb[int(0.1 * height) : int(0.9 * height), : int(0.75 * width)]  # the 3D plot area
    far_from_bg = np.min(np.abs(plot[..., None, :] - BACKGROUND).max(axis=-1), axis=-1) > 40
    assert far_from_bg.mean() > 0.003, "the plot area is (almost) blank"  # 0.9 % for this sparse scene
    assert near(plot, CAMERA_COLOUR).sum() > 100, "no camera frustum drawn"
    red = (plot[..., 0] > 150) & (plot[..., 1] < 90) & (plot[..., 2] < 90)
    assert red.sum() > 100, f"no estimate drawn in red ({ESTIMATE_COLOUR})"


def test_the_scene_is_not_cut_at_the_left_edge(browser_run: tuple[Path, dict[str, Any], str, Path, tuple[int, int]]) -> None:
    """The 3D box's grey panes end well inside the window: plotly cuts a scene that does not fit at the left edge
    of the plot area (the page margin, a few pixels), as it did at 1400 x 1800."""
    _, _, _, shot, size = browser_run
    rgb = screenshot_rgb(shot, size)
    panes = np.nonzero(near(rgb, BACKGROUND[1], tol=4).any(axis=0))[0]
    assert len(panes), "no 3D panes in the screenshot: the check would pass on a blank page"
    assert panes[0] > MIN_LEFT_GAP_PX, f"the 3D box reaches x = {panes[0]} px: cut at the left edge"


def test_legend_menu_and_caption_are_on_screen_and_apart(
    browser_run: tuple[Path, dict[str, Any], str, Path, tuple[int, int]],
) -> None:
    page, report, _, _, _ = browser_run
    width, height = report["window"]
    boxes = {k: report[k] for k in ("legend", "menu", "caption")}
    assert all(b is not None for b in boxes.values()), boxes
    for name, (x0, y0, x1, y1) in boxes.items():
        assert 0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height, f"{name} is (partly) off screen: {boxes[name]}"

    def apart(a: list[float], b: list[float]) -> bool:
        return a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]

    assert apart(boxes["legend"], boxes["menu"]) and apart(boxes["legend"], boxes["caption"])
    layout = figure_json_from_html(page.read_text())["layout"]
    assert "coloraxis" not in layout or not layout["coloraxis"].get("showscale")  # no colour bar over the axes


def test_the_probe_catches_a_page_error(tmp_path: Path) -> None:
    """The harness can fail: a page whose script throws is reported."""
    bad = tmp_path / "bad.html"
    bad.write_text('<html><head></head><body><div id="mv3d-scene"></div><script>notDefined();</script></body></html>')
    report, log = run_browser(bad, tmp_path)
    assert any("notDefined" in e for e in report["errors"])
