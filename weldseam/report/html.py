"""One self-contained HTML page: the interactive 3D view (plotly, its JavaScript embedded)
and a panel with the run's seams, timings, warnings and parameters. No network request.

Size: plotly.js alone is 4.8 MB and 60k scan points written as full floats were 5.5 MB more.
Both are embedded gzip-compressed (base64), and the page unpacks them with the browser's
DecompressionStream (Chrome 80, Firefox 113, Safari 16.4 and later); scan points are written
to 0.1 mm (SCAN_DECIMALS), which the eye cannot tell from the scan's own noise. A 60k-point
report is ~2.5 MB.
"""

from __future__ import annotations

import base64
import functools
import gzip
import html
import json

import numpy as np

from weldseam.report.figure import CONFIDENCE_RAMP, RAMP, Drawing, pose_summary

FIGURE_ID = "weldseam-figure"
# Scan points to 0.1 mm; paths, arrows and marks to 1 um (they are few, and hovering shows them).
SCAN_DECIMALS = 4
PATH_DECIMALS = 6
# Colour values to 1/1000 of their colour span; pose confidences as the path JSON writes them.
COLOUR_STEPS = 1000
CONFIDENCE_DECIMALS = 3
UNSURE_MARKER_PX = 8
# Room on the right for the colour bar, its ticks and its title (they were cut off at 0).
MARGIN_RIGHT_PX = 110


def figure_dict(drawing: Drawing, title: str) -> dict:
    """The plotly figure as a plain dict (traces named so tests and people can find them)."""
    scan = np.round(drawing.scan_m, SCAN_DECIMALS)
    low, high = (np.percentile(drawing.scan_values, [2, 98]) if len(scan) else (0.0, 1.0))
    value_decimals = max(0, int(np.ceil(-np.log10(max(high - low, 1e-12) / COLOUR_STEPS))))
    traces = [
        {
            "type": "scatter3d",
            "mode": "markers",
            "name": "scan",
            "x": scan[:, 0],
            "y": scan[:, 1],
            "z": scan[:, 2],
            "marker": {
                "size": 1.5,
                "color": np.round(drawing.scan_values, value_decimals),
                "colorscale": _colour_scale(RAMP),
                "cmin": float(low),
                "cmax": float(high),
                "colorbar": {"title": {"text": drawing.value_name}, "len": 0.45, "y": 0.75},
            },
            "hoverinfo": "skip",
        }
    ]
    if len(drawing.candidates_m):
        c = np.round(drawing.candidates_m, SCAN_DECIMALS)
        traces.append(
            {
                "type": "scatter3d",
                "mode": "markers",
                "name": "seam candidates",
                "x": c[:, 0],
                "y": c[:, 1],
                "z": c[:, 2],
                "marker": {"size": 2, "color": "rgba(0,190,255,0.7)"},
                "hoverinfo": "skip",
            }
        )
    for k, seam in enumerate(drawing.seams):
        p = np.round(seam.positions_m, PATH_DECIMALS)
        confidence = np.round(seam.pose_confidence, CONFIDENCE_DECIMALS)
        # One scale for every seam's poses, its bar drawn once (below the scan's).
        shade = {"color": confidence, "colorscale": _colour_scale(CONFIDENCE_RAMP), "cmin": 0.0, "cmax": 1.0}
        bar = {"showscale": True, "colorbar": {"title": {"text": "pose confidence"}, "len": 0.45, "y": 0.25}}
        traces.append(
            {
                "type": "scatter3d",
                "mode": "lines+markers",
                "name": seam.label,
                "x": p[:, 0],
                "y": p[:, 1],
                "z": p[:, 2],
                "customdata": np.column_stack([np.arange(len(p)), confidence]),
                "line": {**shade, "width": 6},
                # Unsure poses get big dots: a pale stretch of line alone is lost on a bright scan.
                "marker": {**shade, "size": np.where(confidence < 1, UNSURE_MARKER_PX, 2),
                           "line": {"color": "#333333", "width": 1}, **(bar if k == 0 else {})},
                "hovertemplate": (
                    f"seam {seam.seam_id} pose %{{customdata[0]:d}}<br>confidence %{{customdata[1]:.2f}}"
                    "<br>x %{x:.4f}<br>y %{y:.4f}<br>z %{z:.4f}<extra></extra>"
                ),
            }
        )
        segments = np.full((3 * len(seam.arrow_tails_m), 3), np.nan)
        segments[0::3], segments[1::3] = seam.arrow_tails_m, seam.arrow_heads_m
        segments = np.round(segments, PATH_DECIMALS)
        traces.append(
            {
                "type": "scatter3d",
                "mode": "lines",
                "name": f"seam {seam.seam_id} torch axis",
                "x": segments[:, 0],
                "y": segments[:, 1],
                "z": segments[:, 2],
                "connectgaps": False,
                "line": {"color": "#222222", "width": 3},
                "hoverinfo": "skip",
            }
        )
        ends = p[[0, -1]]
        traces.append(
            {
                "type": "scatter3d",
                "mode": "markers+text",
                "name": f"seam {seam.seam_id} start/end",
                "x": ends[:, 0],
                "y": ends[:, 1],
                "z": ends[:, 2],
                "text": [f"{seam.seam_id} start", f"{seam.seam_id} end"],
                "textposition": "top center",
                "marker": {"size": 6, "color": ["#00a000", "#d00000"], "symbol": "diamond"},
            }
        )
    layout = {
        "title": {"text": title},
        "margin": {"l": 0, "r": MARGIN_RIGHT_PX, "t": 40, "b": 0},
        "showlegend": True,
        "legend": {"x": 0, "y": 1},
        "scene": _scene(drawing),
    }
    return {"data": traces, "layout": layout}


def _colour_scale(ramp: np.ndarray) -> list:
    """A plotly colorscale through the evenly spaced RGB stops of `ramp`."""
    return [[k / (len(ramp) - 1), f"rgb({r:.0f},{g:.0f},{b:.0f})"] for k, (r, g, b) in enumerate(ramp)]


def _scene(drawing: Drawing) -> dict:
    """Equal scale on all axes over the bulk of the scan (stray points beyond its 0.5-99.5th
    percentiles and the paths' extent do not shrink the part to a dot)."""
    scan = drawing.scan_m
    bulk = [np.percentile(scan, [0.5, 99.5], axis=0)] if len(scan) else []
    bounds = np.vstack(bulk + [seam.positions_m for seam in drawing.seams])
    if len(bounds) == 0:
        return {"aspectmode": "data"}
    low, high = bounds.min(axis=0), bounds.max(axis=0)
    pad = 0.05 * (high - low).max() + 1e-3
    low, high = low - pad, high + pad
    ratio = (high - low) / (high - low).max()
    axes = {
        name: {"title": {"text": f"{name} (m)"}, "range": [float(low[k]), float(high[k])]}
        for k, name in enumerate("xyz")
    }
    return {
        "aspectmode": "manual",
        "aspectratio": dict(zip("xyz", map(float, ratio))),
        **{f"{name}axis": axis for name, axis in axes.items()},
    }


def report_html(drawing: Drawing, record: dict, title: str) -> str:
    """The whole page as text (the same drawing and record give the same bytes)."""
    import plotly.io

    figure = figure_dict(drawing, title)
    figure["layout"]["template"] = plotly.io.templates[plotly.io.templates.default].to_plotly_json()
    return _PAGE.format(
        title=html.escape(title),
        figure_id=FIGURE_ID,
        plotly_js=_packed_plotly_js(),
        figure=packed(json.dumps(figure, cls=_ArrayEncoder, separators=(",", ":"), allow_nan=False)),
        panel=_panel(record),
    )


def packed(text: str) -> str:
    """base64(gzip(UTF-8 text)), with no timestamp in the gzip header (the same text, the same bytes).
    Level 6: level 9 took 0.9 s more on 60k points for 5 % less."""
    return base64.b64encode(gzip.compress(text.encode("utf-8"), compresslevel=6, mtime=0)).decode("ascii")


@functools.lru_cache(maxsize=1)
def _packed_plotly_js() -> str:
    """plotly.js from the installed plotly package, packed (0.1 s, once per process)."""
    from plotly.offline import get_plotlyjs

    return packed(get_plotlyjs())


class _ArrayEncoder(json.JSONEncoder):
    def default(self, value):
        if isinstance(value, np.ndarray):  # NaN (a gap between arrows) is null in JSON
            return np.where(np.isnan(value), None, value).tolist() if value.dtype.kind == "f" else value.tolist()
        if isinstance(value, np.generic):
            return value.item()
        return super().default(value)


def _panel(record: dict) -> str:
    seams = record.get("seams", [])
    rows = "".join(_seam_row(seam) for seam in seams) or '<tr><td colspan="8">no seam found</td></tr>'
    timings = record.get("timings_s", {})
    timing_rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{v * 1000:.1f}</td></tr>" for k, v in timings.items())
    total = sum(timings.values())
    warnings = record.get("warnings", [])
    warning_items = "".join(f"<li>{html.escape(w)}</li>" for w in warnings) or "<li>none</li>"
    source = record.get("input", {})
    params = html.escape(json.dumps(record.get("params", {}), indent=2))
    return (
        f"<section><h2>Seams</h2><table><tr><th>id</th><th>joint</th><th>length mm</th><th>poses</th>"
        f"<th>confidence</th><th>lowest pose confidence</th><th>poses below 1</th><th>closed</th></tr>{rows}</table>"
        f"<h2>Warnings</h2><ul>{warning_items}</ul>"
        f"<h2>Input</h2><p>{html.escape(str(source.get('path', '')))}<br>{source.get('points', '')} points<br>"
        f"<small>sha256 {html.escape(str(source.get('sha256', '')))}</small></p></section>"
        f"<section><h2>Stage timings</h2><table><tr><th>stage</th><th>ms</th></tr>{timing_rows}"
        f"<tr><th>total</th><th>{total * 1000:.1f}</th></tr></table></section>"
        f"<section><h2>Parameters</h2><details><summary>effective values</summary><pre>{params}</pre>"
        "</details></section>"
    )


def _seam_row(seam: dict) -> str:
    lowest, below = pose_summary(seam)
    cells = (
        seam.get("id"),
        html.escape(str(seam.get("joint") or "unknown")),
        f"{seam.get('length_m', 0) * 1000:.1f}",
        len(seam.get("poses", [])),
        f"{seam.get('confidence', 0):.2f}",
        f"{lowest:.2f}",
        below,
        "yes" if seam.get("closed") else "no",
    )
    return "<tr>" + "".join(f"<td>{cell}</td>" for cell in cells) + "</tr>"


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>
body {{ font-family: sans-serif; margin: 0; background: #fafafa; color: #222; }}
#view {{ width: 100%; overflow: hidden; }}
#panel {{ display: flex; flex-wrap: wrap; gap: 8px 40px; padding: 0 16px 16px; border-top: 1px solid #ddd;
          font-size: 14px; }}
#panel section {{ min-width: 260px; max-width: 520px; }}
table {{ border-collapse: collapse; width: 100%; }}
td, th {{ border-bottom: 1px solid #e5e5e5; padding: 3px 6px; text-align: right; }}
td:first-child, th:first-child {{ text-align: left; }}
h2 {{ font-size: 15px; margin-top: 20px; }}
pre {{ font-size: 11px; }}
</style></head>
<body><div id="view"><div id="{figure_id}" style="height: 80vh; width: 100%;"></div>
<p id="weldseam-status">Unpacking the 3D view...</p></div>
<div id="panel">{panel}</div>
<script type="application/octet-stream" id="weldseam-plotly-js">{plotly_js}</script>
<script type="application/octet-stream" id="weldseam-figure-data">{figure}</script>
<script>
async function weldseamUnpack(id) {{
  const bytes = Uint8Array.from(atob(document.getElementById(id).textContent), c => c.charCodeAt(0));
  const stream = new DecompressionStream("gzip");
  const writer = stream.writable.getWriter();
  writer.write(bytes);
  writer.close();
  const reader = stream.readable.getReader(), decoder = new TextDecoder();
  let text = "";
  for (let part = await reader.read(); !part.done; part = await reader.read()) {{
    text += decoder.decode(part.value, {{stream: true}});
  }}
  return text + decoder.decode();
}}
(async () => {{
  const status = document.getElementById("weldseam-status");
  try {{
    const library = document.createElement("script");
    library.textContent = await weldseamUnpack("weldseam-plotly-js");
    document.head.appendChild(library);
    const figure = JSON.parse(await weldseamUnpack("weldseam-figure-data"));
    await Plotly.newPlot("{figure_id}", figure.data, figure.layout, {{displaylogo: false, responsive: true}});
    status.remove();
  }} catch (error) {{
    status.textContent = "This browser could not unpack the 3D view (" + error + "); it needs Chrome 80, " +
      "Firefox 113, Safari 16.4 or later. The tables below, the PNG report and the path JSON hold the results.";
  }}
}})();
</script>
</body></html>
"""
