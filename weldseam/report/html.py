"""One self-contained HTML page: the interactive 3D view (plotly, its JavaScript embedded)
and a panel with the run's seams, timings, warnings and parameters. No network request."""

from __future__ import annotations

import html
import json

import numpy as np

from weldseam.report.figure import RAMP, Drawing

FIGURE_ID = "weldseam-figure"
PATH_COLOURS = ("#e6194b", "#f58231", "#ff00ff", "#ff4500", "#dc143c", "#ff69b4")


def figure_dict(drawing: Drawing, title: str) -> dict:
    """The plotly figure as a plain dict (traces named so tests and people can find them)."""
    scan = drawing.scan_m
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
                "color": drawing.scan_values,
                "colorscale": [
                    [k / (len(RAMP) - 1), f"rgb({r:.0f},{g:.0f},{b:.0f})"] for k, (r, g, b) in enumerate(RAMP)
                ],
                "cmin": float(np.percentile(drawing.scan_values, 2)) if len(scan) else 0.0,
                "cmax": float(np.percentile(drawing.scan_values, 98)) if len(scan) else 1.0,
                "colorbar": {"title": {"text": drawing.value_name}, "len": 0.5},
            },
            "hoverinfo": "skip",
        }
    ]
    if len(drawing.candidates_m):
        c = drawing.candidates_m
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
        colour = PATH_COLOURS[k % len(PATH_COLOURS)]
        p = seam.positions_m
        traces.append(
            {
                "type": "scatter3d",
                "mode": "lines+markers",
                "name": seam.label,
                "x": p[:, 0],
                "y": p[:, 1],
                "z": p[:, 2],
                "line": {"color": colour, "width": 6},
                "marker": {"size": 2, "color": colour},
                "hovertemplate": f"seam {seam.seam_id}<br>x %{{x:.4f}}<br>y %{{y:.4f}}<br>z %{{z:.4f}}<extra></extra>",
            }
        )
        segments = np.full((3 * len(seam.arrow_tails_m), 3), np.nan)
        segments[0::3], segments[1::3] = seam.arrow_tails_m, seam.arrow_heads_m
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
        "margin": {"l": 0, "r": 0, "t": 40, "b": 0},
        "showlegend": True,
        "legend": {"x": 0, "y": 1},
        "scene": _scene(drawing),
    }
    return {"data": traces, "layout": layout}


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
    """The whole page as text."""
    import plotly.io

    figure = plotly.io.from_json(json.dumps(figure_dict(drawing, title), cls=_ArrayEncoder))
    plot = figure.to_html(
        full_html=False,
        include_plotlyjs=True,
        include_mathjax=False,
        div_id=FIGURE_ID,
        config={"displaylogo": False, "responsive": True},
        default_height="80vh",
    )
    return _PAGE.format(title=html.escape(title), plot=plot, panel=_panel(record))


class _ArrayEncoder(json.JSONEncoder):
    def default(self, value):
        if isinstance(value, np.ndarray):
            return [None if isinstance(v, float) and np.isnan(v) else v for v in value.tolist()]
        if isinstance(value, np.generic):
            return value.item()
        return super().default(value)


def _panel(record: dict) -> str:
    seams = record.get("seams", [])
    rows = "".join(_seam_row(seam) for seam in seams) or '<tr><td colspan="6">no seam found</td></tr>'
    timings = record.get("timings_s", {})
    timing_rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{v * 1000:.1f}</td></tr>" for k, v in timings.items())
    total = sum(timings.values())
    warnings = record.get("warnings", [])
    warning_items = "".join(f"<li>{html.escape(w)}</li>" for w in warnings) or "<li>none</li>"
    source = record.get("input", {})
    params = html.escape(json.dumps(record.get("params", {}), indent=2))
    return (
        f"<section><h2>Seams</h2><table><tr><th>id</th><th>joint</th><th>length mm</th><th>poses</th>"
        f"<th>confidence</th><th>closed</th></tr>{rows}</table>"
        f"<h2>Warnings</h2><ul>{warning_items}</ul>"
        f"<h2>Input</h2><p>{html.escape(str(source.get('path', '')))}<br>{source.get('points', '')} points<br>"
        f"<small>sha256 {html.escape(str(source.get('sha256', '')))}</small></p></section>"
        f"<section><h2>Stage timings</h2><table><tr><th>stage</th><th>ms</th></tr>{timing_rows}"
        f"<tr><th>total</th><th>{total * 1000:.1f}</th></tr></table></section>"
        f"<section><h2>Parameters</h2><details><summary>effective values</summary><pre>{params}</pre>"
        "</details></section>"
    )


def _seam_row(seam: dict) -> str:
    cells = (
        seam.get("id"),
        html.escape(str(seam.get("joint"))),
        f"{seam.get('length_m', 0) * 1000:.1f}",
        len(seam.get("poses", [])),
        f"{seam.get('confidence', 0):.2f}",
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
<body><div id="view">{plot}</div><div id="panel">{panel}</div></body></html>
"""
