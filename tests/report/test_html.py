import base64
import gzip
import json
import re

import numpy as np

from weldseam.report.figure import CONFIDENCE_RAMP, make_drawing
from weldseam.report.html import report_html


def unpacked(page: str, script_id: str) -> str:
    """The text a packed <script> of the page holds (base64 of gzip), as the page's loader unpacks it."""
    packed = re.search(rf'<script type="application/octet-stream" id="{script_id}">([^<]*)</script>', page).group(1)
    return gzip.decompress(base64.b64decode(packed)).decode("utf-8")


def embedded_figure(page: str) -> list[dict]:
    return json.loads(unpacked(page, "weldseam-figure-data"))["data"]


def test_the_page_holds_the_scan_the_path_its_axes_and_its_ends(plate_and_path):
    points, (path,), record = plate_and_path
    page = report_html(make_drawing(points, [path], point_budget=2000), record, "plate")
    traces = {trace["name"]: trace for trace in embedded_figure(page)}
    assert len(traces["scan"]["x"]) == 2000
    line = traces["seam 0 (v_groove)"]
    assert np.allclose(np.column_stack([line["x"], line["y"], line["z"]]), path.positions_m)
    axes = traces["seam 0 torch axis"]
    tails = np.array([axes["x"][0::3], axes["y"][0::3], axes["z"][0::3]]).T
    heads = np.array([axes["x"][1::3], axes["y"][1::3], axes["z"][1::3]]).T
    assert np.allclose(heads - tails, [0.0, 0.0, -0.015])  # along the torch axis, into the work
    ends = traces["seam 0 start/end"]
    assert np.allclose([ends["x"][0], ends["x"][1]], path.positions_m[[0, -1], 0])
    assert "<td>v_groove</td>" in page and "a warning &lt;b&gt;escaped&lt;/b&gt;" in page


def test_the_page_needs_no_network(plate_and_path):
    points, paths, record = plate_and_path
    page = report_html(make_drawing(points, paths, point_budget=500), record, "plate")
    assert not re.search(r"<script[^>]*\bsrc=", page) and "<link" not in page and "<img" not in page
    # plotly.js itself carries URL constants (the topojson and map tile defaults, fetched only
    # by geo and map traces, which the report does not use); the markup must have none.
    markup = re.sub(r"<script.*?</script>", "", page, flags=re.S)
    assert "http" not in markup
    assert {trace["type"] for trace in embedded_figure(page)} == {"scatter3d"}
    assert "MathJax.js" not in page and "cdn.plot.ly/plotly" not in page


def test_the_page_embeds_plotly_js_whole_and_a_figure_plotly_accepts(plate_and_path):
    import plotly.io
    from plotly.offline import get_plotlyjs

    points, paths, record = plate_and_path
    page = report_html(make_drawing(points, paths, point_budget=500), record, "plate")
    assert unpacked(page, "weldseam-plotly-js") == get_plotlyjs()
    figure = json.loads(unpacked(page, "weldseam-figure-data"))
    assert plotly.io.from_json(json.dumps(figure)).layout.title.text == "plate"  # plotly's own schema check
    assert figure["layout"]["margin"]["r"] > 0  # room for the colour bar


def test_scan_points_are_written_to_0_1_mm_and_paths_to_1_um(plate_and_path):
    points, (path,), record = plate_and_path
    drawing = make_drawing(points, [path], point_budget=2000)
    traces = {trace["name"]: trace for trace in embedded_figure(report_html(drawing, record, "plate"))}
    scan = np.column_stack([traces["scan"]["x"], traces["scan"]["y"], traces["scan"]["z"]])
    assert np.abs(scan - drawing.scan_m).max() <= 0.5e-4 + 1e-12
    assert np.array_equal(scan, np.round(drawing.scan_m, 4))
    line = traces["seam 0 (v_groove)"]
    assert np.abs(np.column_stack([line["x"], line["y"], line["z"]]) - path.positions_m).max() <= 0.5e-6 + 1e-12
    colour = np.array(traces["scan"]["marker"]["color"])
    span = traces["scan"]["marker"]["cmax"] - traces["scan"]["marker"]["cmin"]
    assert np.abs(colour - drawing.scan_values).max() <= span / 1000


def test_a_report_of_60k_points_stays_under_3_mb_and_is_deterministic(rng_points_60k):
    """It was 10.3 MB: plotly.js 4.8 MB and the points at full float precision 5.5 MB."""
    points, paths, record = rng_points_60k
    drawing = make_drawing(points, paths)  # the default budget
    assert len(drawing.scan_m) == 60000
    page = report_html(drawing, record, "plate")
    assert len(page.encode("utf-8")) < 3_000_000
    assert report_html(drawing, record, "plate") == page


def test_the_path_is_coloured_by_pose_confidence_on_a_scale_with_a_bar(unsure_path):
    """Issue 21: a pose that rests on an unseen face or an interpolated hole says so on the page."""
    points, path, record = unsure_path
    page = report_html(make_drawing(points, [path], point_budget=2000), record, "plate")
    line = {trace["name"]: trace for trace in embedded_figure(page)}["seam 0 (v_groove)"]
    for shaded in (line["line"], line["marker"]):
        assert shaded["color"] == path.pose_confidence.tolist()
        assert (shaded["cmin"], shaded["cmax"]) == (0, 1)
        scale = [[stop, tuple(map(int, re.findall(r"\d+", rgb)))] for stop, rgb in shaded["colorscale"]]
        assert scale[0] == [0, (255, 255, 255)] and scale[-1] == [1, tuple(CONFIDENCE_RAMP[-1])]
    sizes = np.array(line["marker"]["size"])
    assert sizes[path.pose_confidence < 1].min() > sizes[path.pose_confidence == 1].max()  # unsure poses stand out
    assert line["marker"]["showscale"] and line["marker"]["colorbar"]["title"]["text"] == "pose confidence"
    assert [row[0] for row in line["customdata"]] == list(range(len(path.positions_m)))  # hover: pose index
    assert [row[1] for row in line["customdata"]] == path.pose_confidence.tolist()  # and its confidence
    assert "pose %{customdata[0]" in line["hovertemplate"] and "confidence %{customdata[1]" in line["hovertemplate"]
    cells = re.findall(r"<td>([^<]*)</td>", page)
    assert cells[4:8] == ["0.90", "0.30", "15", "no"]  # seam confidence, lowest pose's, poses below 1, closed
    assert "<th>lowest pose confidence</th><th>poses below 1</th>" in page


def test_a_path_without_pose_confidence_is_drawn_at_full_confidence(plate_and_path):
    points, paths, record = plate_and_path  # a WeldPath with pose_confidence None (as read from CSV)
    page = report_html(make_drawing(points, paths, point_budget=500), record, "plate")
    line = {trace["name"]: trace for trace in embedded_figure(page)}["seam 0 (v_groove)"]
    assert line["marker"]["color"] == [1.0] * len(paths[0].positions_m)
    assert re.findall(r"<td>([^<]*)</td>", page)[4:8] == ["0.90", "1.00", "0", "no"]
