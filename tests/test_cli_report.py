"""`weldseam report` and `plan --report`, run as a user would."""

import json
import subprocess
import sys
from html import escape
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


def test_report_refuses_an_extension_it_does_not_write_before_any_work(tmp_path):
    for option, name in (("-o", "r.pdf"), ("--png", "r.jpg"), ("-o", "r.png")):
        result = weldseam("report", "samples/v_butt.ply", "samples/golden/v_butt.json", option, tmp_path / name)
        assert result.returncode == 2
        suffix = ".html" if option == "-o" else ".png"
        assert result.stderr.decode() == f"Error: {option} {tmp_path / name}: the report writes {suffix} files only\n"
        assert list(tmp_path.iterdir()) == []


def test_a_camera_frame_scan_under_a_base_frame_path_is_drawn_with_a_warning(tmp_path):
    lone = tmp_path / "lone.png"  # no pose beside it, and the path's record holds none
    lone.write_bytes((ROOT / "samples" / "fillet_t.png").read_bytes())
    document = json.loads((ROOT / "samples" / "golden" / "fillet_t.json").read_text())
    del document["input"]["placement"]
    path = tmp_path / "path.json"
    path.write_text(json.dumps(document))
    html = tmp_path / "r.html"
    result = weldseam("report", lone, path, "--intrinsics", "samples/d415.intrinsics.json", "-o", html)
    assert result.returncode == 0, result.stderr
    warning = (f"the scan is in the camera frame but {path} is in the base frame: they are "
               "drawn apart; give the scan's placement (--camera-pose, --flange-pose or --joints with --hand-eye)")
    assert f"Warning: {warning}" in result.stderr.decode()
    assert escape(warning) in html.read_text()  # in the page's warnings too
    placed = weldseam("report", lone, path, "--intrinsics", "samples/d415.intrinsics.json",
                      "--camera-pose", "samples/fillet_t.pose.json", "-o", html)
    assert placed.returncode == 0 and "Warning" not in placed.stderr.decode()


def test_a_path_planned_from_another_scan_is_drawn_with_a_warning(tmp_path):
    result = weldseam("report", "samples/v_butt.ply", "samples/golden/fillet_t.json", "-o", tmp_path / "r.html")
    assert result.returncode == 0, result.stderr
    assert ("Warning: samples/v_butt.ply: its sha256 is not the one samples/golden/fillet_t.json was planned from: "
            "the path may belong to another scan") in result.stderr.decode()
    same = weldseam("report", "samples/v_butt.ply", "samples/golden/v_butt.json", "-o", tmp_path / "r.html")
    assert same.returncode == 0 and "sha256" not in same.stderr.decode()


def test_without_placement_options_the_scan_is_placed_as_the_path_records_it(tmp_path):
    scan = tmp_path / "part.png"  # no pose beside it: only the record can place it
    scan.write_bytes((ROOT / "samples" / "fillet_t.png").read_bytes())
    path = tmp_path / "path.json"
    planned = weldseam("plan", scan, "--intrinsics", "samples/d415.intrinsics.json", "--camera-pose",
                       "samples/fillet_t.pose.json", "-o", path, "-q")
    assert planned.returncode == 0, planned.stderr
    result = weldseam("report", scan, path, "-o", tmp_path / "r.html")
    assert result.returncode == 0, result.stderr
    assert result.stderr.decode().splitlines() == [
        f"{scan}: intrinsics and camera pose from the record of {path}", f"report of 1 seam(s) -> {tmp_path / 'r.html'}"
    ]


def test_report_and_plan_share_one_group_of_placement_options():
    from weldseam.commands import plan, report

    group = {"scans", "frames", "intrinsics", "camera_pose", "flange_pose", "joints", "hand_eye", "robot",
             "cloud_frame", "camera_origin", "units"}
    for command in (plan.plan, report.report):
        hints = command.__annotations__
        assert group <= set(hints), command
    assert all(plan.plan.__annotations__[name] == report.report.__annotations__[name] for name in group)
    helps = [weldseam(name, "--help").stdout.decode() for name in ("plan", "report")]
    for option in ("--frames", "--intrinsics", "--camera-pose", "--flange-pose", "--joints", "--hand-eye", "--robot",
                   "--cloud-frame", "--camera-origin", "--units"):
        assert all(option in text for text in helps), option


def test_report_of_several_frames_places_each_like_plan(tmp_path):
    made = subprocess.run([sys.executable, "-m", "weldseam.synthetic.multiview", "frames", "pipe"], cwd=tmp_path,
                          capture_output=True, timeout=180)
    assert made.returncode == 0, made.stderr
    frames = [tmp_path / "frames" / f"f{k}.png" for k in range(4)]
    ring = tmp_path / "ring.json"
    assert weldseam("plan", *frames, "--hand-eye", tmp_path / "frames" / "H.json", "-o", ring, "-q").returncode == 0
    result = weldseam("report", *frames, ring, "--hand-eye", tmp_path / "frames" / "H.json", "-o", tmp_path / "r.html")
    assert result.returncode == 0, result.stderr
    lines = result.stderr.decode().splitlines()
    assert [line for line in lines if "sha256" in line or "frame but" in line] == []
    assert f"{frames[0]}: camera pose from {tmp_path / 'frames' / 'f0.pose.json'} (beside the scan)" in lines
