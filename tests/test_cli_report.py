"""`weldseam report` and `plan --report`, run as a user would."""

import json
import subprocess
import sys
from pathlib import Path

from PIL import Image

from tests.report.test_html import embedded_figure

ROOT = Path(__file__).resolve().parents[1]


def weldseam(*args):
    return subprocess.run(
        [sys.executable, "-m", "weldseam.cli", *map(str, args)], capture_output=True, timeout=180, cwd=ROOT
    )


def test_report_of_a_golden_path_writes_the_page_and_the_picture(tmp_path):
    html, png = tmp_path / "r.html", tmp_path / "r.png"
    result = weldseam(
        "report", "samples/v_butt.ply", "samples/golden/v_butt.json", "--camera-pose", "samples/v_butt.pose.json",
        "-o", html, "--png", png, "--color", "descriptor", "--point-budget", "20000",
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout == b""
    page = html.read_text()
    names = {trace["name"] for trace in embedded_figure(page)}  # the figure is packed (tests/report/test_html.py)
    assert {"seam 0 (v_groove)", "seam candidates"} <= names
    assert "<td>v_groove</td>" in page and "descriptor" in json.dumps(embedded_figure(page))
    assert Image.open(png).size == (1660, 800)  # the view and, beside it, the seam table and warnings


def test_plan_writes_a_report_while_planning(tmp_path):
    png = tmp_path / "plan.png"
    result = weldseam(
        "plan", "samples/fillet_t.png", "--intrinsics", "samples/d415.intrinsics.json", "--camera-pose",
        "samples/fillet_t.pose.json", "-o", tmp_path / "path.json", "--report", png, "-q",
    )
    assert result.returncode == 0, result.stderr
    assert png.stat().st_size > 10000


def test_report_refuses_what_it_cannot_do_in_one_line(tmp_path):
    nothing = weldseam("report", "samples/v_butt.ply", "samples/golden/v_butt.json")
    assert nothing.returncode == 2 and nothing.stderr.decode().startswith("Error: nothing to write")
    missing = weldseam("report", "samples/v_butt.ply", tmp_path / "none.json", "-o", tmp_path / "r.html")
    assert missing.returncode == 2 and len(missing.stderr.decode().strip().splitlines()) == 1
    assert not (tmp_path / "r.html").exists()
    bad = weldseam("plan", "samples/v_butt.ply", "-o", tmp_path / "p.json", "--report", tmp_path / "r.pdf")
    assert bad.returncode == 2 and "--report" in bad.stderr.decode() and not (tmp_path / "p.json").exists()
