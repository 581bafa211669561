"""The scene HTML in a real browser: headless Chromium loads it without errors and draws the scene.

Chromium (Debian package ``chromium``; ``.ci/run`` installs it when missing) loads a copy of
the page with a small probe script added at the top of ``<head>``: the probe records uncaught
errors and ``console.error`` calls and, once the page has loaded, writes them with the number of
traces plotly drew into a ``<pre>`` element that ``--dump-dom`` prints. The same run takes a
screenshot, in which the 3D plot area must show the cameras (non-background pixels in the
frustums' colour). No DevTools connection is needed.
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

from monovisual3d.viz3d import CAMERA_COLOUR, figure_json_from_html, write_scene_html  # noqa: E402
from test_viz3d import result_dict, truth_dict, two_fruit_session  # noqa: E402

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
    pre.textContent = JSON.stringify({errors: window.__mv3dErrors, traces: gd && gd._fullData ? gd._fullData.length : -1});
    document.body.appendChild(pre);
  }, 500);
});
</script>"""
WIDTH, HEIGHT = 1200, 800


def run_browser(page: Path, tmp: Path, screenshot: Path | None = None) -> tuple[dict[str, Any], str]:
    """Load ``page`` with the probe; returns the probe's report and Chromium's log (stderr)."""
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
        f"--window-size={WIDTH},{HEIGHT}",
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


@pytest.fixture(scope="module")
def browser_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any], str, Path]:
    tmp = tmp_path_factory.mktemp("browser")
    page = write_scene_html(two_fruit_session(), result_dict(), truth_dict(), path=tmp / "scene.html")
    shot = tmp / "shot.png"
    report, log = run_browser(page, tmp, shot)
    return page, report, log, shot


def test_page_loads_without_errors(browser_run: tuple[Path, dict[str, Any], str, Path]) -> None:
    page, report, log, _ = browser_run
    assert report["errors"] == []
    assert uncaught_console_errors(log) == []
    assert report["traces"] == len(figure_json_from_html(page.read_text())["data"])  # plotly drew every trace


def test_screenshot_shows_the_scene(browser_run: tuple[Path, dict[str, Any], str, Path]) -> None:
    mpimg = pytest.importorskip("matplotlib.image")
    _, _, _, shot = browser_run
    rgb = (255 * mpimg.imread(shot)[..., :3]).astype(int)
    assert rgb.shape[:2] == (HEIGHT, WIDTH)
    plot = rgb[int(0.1 * HEIGHT) : int(0.95 * HEIGHT), int(0.1 * WIDTH) : int(0.7 * WIDTH)]  # the 3D plot area
    background = np.array([[255, 255, 255], [229, 236, 246]])  # page, plotly's 3D scene background
    far_from_bg = np.min(np.abs(plot[..., None, :] - background).max(axis=-1), axis=-1) > 40
    assert far_from_bg.mean() > 0.01, "the plot area is (almost) blank"
    camera = np.array([int(CAMERA_COLOUR[k : k + 2], 16) for k in (1, 3, 5)])
    assert (np.abs(plot - camera).max(axis=-1) < 40).sum() > 100, "no camera frustum drawn"


def test_the_probe_catches_a_page_error(tmp_path: Path) -> None:
    """The harness can fail: a page whose script throws is reported."""
    bad = tmp_path / "bad.html"
    bad.write_text('<html><head></head><body><div id="mv3d-scene"></div><script>notDefined();</script></body></html>')
    report, log = run_browser(bad, tmp_path)
    assert any("notDefined" in e for e in report["errors"])
