"""The page renders in a real browser (Debian's chromium, headless, network closed)."""

import json
import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from weldseam.report import write_report
from weldseam.report.html import FIGURE_ID

CHROMIUM = shutil.which("chromium")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (make test installs it)")

# Run in the page once the plot is drawn: where every colour-bar text lies against the plot's own
# SVG and the window's width left of the scroll bar (what falls outside is cut off or hidden),
# written into the DOM for --dump-dom.
MEASURE = """<script>
const started = Date.now();
const timer = setInterval(() => {
  const svg = document.querySelector("#%s .main-svg");
  const texts = document.querySelectorAll("#%s .colorbar text");
  if (!(svg && texts.length) && Date.now() - started < 20000) return;
  clearInterval(timer);
  const box = svg ? svg.getBoundingClientRect() : {left: 0, right: 0, top: 0, bottom: 0};
  const out = document.createElement("pre");
  out.id = "measured";
  out.textContent = JSON.stringify({
    svg: [box.left, box.top, Math.min(box.right, document.documentElement.clientWidth), box.bottom],
    texts: Array.from(texts, t => { const r = t.getBoundingClientRect();
                                    return {text: t.textContent, box: [r.left, r.top, r.right, r.bottom]}; }),
    status: document.getElementById("weldseam-status") ? document.getElementById("weldseam-status").textContent : null,
  });
  document.body.appendChild(out);
}, 100);
</script>""" % (FIGURE_ID, FIGURE_ID)


def chromium(page, tmp_path, *args):
    return subprocess.run(
        [
            CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
            "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}",
            "--host-resolver-rules=MAP * ~NOTFOUND", "--window-size=1200,900", "--virtual-time-budget=20000", *args, page.as_uri(),
        ],
        capture_output=True, timeout=180, check=True,
    )  # fmt: skip


def test_chromium_draws_the_scan_and_the_path(plate_and_path, tmp_path):
    points, paths, record = plate_and_path
    page = tmp_path / "report.html"
    write_report(points, paths, record, page, point_budget=20000)
    shot = tmp_path / "shot.png"
    chromium(page, tmp_path, f"--screenshot={shot}")
    image = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert image.std() > 10  # not a blank page
    path_red = np.all(np.abs(image - [230, 25, 75]) <= 30, axis=2).sum()
    plate = np.all(np.abs(image - [33, 145, 140]) <= 60, axis=2).sum()  # mid-ramp colours of the scan
    assert path_red > 100 and plate > 1000


def test_the_colour_bar_title_and_ticks_are_whole_inside_the_plot(plate_and_path, tmp_path):
    """They were cut off at the page's right edge (no right margin)."""
    points, paths, record = plate_and_path
    page = tmp_path / "report.html"
    write_report(points, paths, record, page, point_budget=5000)
    page.write_text(page.read_text().replace("</body>", MEASURE + "</body>"))
    dom = chromium(page, tmp_path, "--dump-dom").stdout.decode()
    measured = json.loads(re.search(r'<pre id="measured">(.*?)</pre>', dom, re.S).group(1).replace("&quot;", '"'))
    assert measured["status"] is None  # the unpacking succeeded and removed its message
    left, top, right, bottom = measured["svg"]
    texts = {entry["text"]: entry["box"] for entry in measured["texts"]}
    assert "height (m)" in texts and len(texts) >= 4  # the title and at least three ticks
    for text, (x0, y0, x1, y1) in texts.items():
        assert left <= x0 and x1 <= right and top <= y0 and y1 <= bottom, (text, measured["svg"])
