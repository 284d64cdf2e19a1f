import json
import re

import numpy as np

from weldseam.report.figure import make_drawing
from weldseam.report.html import FIGURE_ID, report_html


def embedded_figure(page: str) -> list[dict]:
    start = page.index("Plotly.newPlot(")
    start = page.index("[", page.index(f'"{FIGURE_ID}"', start))
    data, _ = json.JSONDecoder().raw_decode(page, start)
    return data


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
