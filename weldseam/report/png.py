"""A static PNG of the report, drawn with Pillow (no browser): on the left the view, the scan as
depth-sorted splats coloured like the HTML, the paths coloured by pose confidence, torch arrows
and start/end marks on top, and a legend with the confidence scale; on the right the HTML's
panel of seams (id, joint, length, poses, confidence, closed, and under a seam with unsure poses
how many and the lowest) and warnings. Timings and parameters are in the HTML and the path JSON."""

from __future__ import annotations

import functools
import io

import numpy as np

from weldseam.report.figure import CONFIDENCE_RAMP, Drawing, colours, confidence_colours, pose_summary

VIEW_WIDTH, PANEL_WIDTH, HEIGHT, MARGIN = 1200, 460, 800, 40
WIDTH = VIEW_WIDTH + PANEL_WIDTH
FONT_SIZE_PX, LINE_PX = 14, 20
PANEL_RGB, TEXT_RGB = (255, 255, 255), (0, 0, 0)
# The seam table: heading, right edge of the column in the panel (px; the first is left-aligned at 0).
SEAM_COLUMNS = (("id", 24), ("joint", 0), ("length mm", 230), ("poses", 290), ("confidence", 375), ("closed", 430))
JOINT_LEFT_PX = 40
ELEVATION_DEG, AZIMUTH_DEG = 40.0, -60.0
# The path at full confidence (CONFIDENCE_RAMP's top); below 1 it pales through amber to white.
PATH_RGB = tuple(int(c) for c in CONFIDENCE_RAMP[-1])
CONFIDENCE_BAR_PX = 120


def view_axes(elevation_deg: float = ELEVATION_DEG, azimuth_deg: float = AZIMUTH_DEG) -> np.ndarray:
    """Rows: screen right, screen up, and the viewing direction (into the screen), for an
    orthographic camera looking down at `elevation_deg` from azimuth `azimuth_deg` (z up)."""
    el, az = np.radians(elevation_deg), np.radians(azimuth_deg)
    toward_eye = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    right = np.cross([0.0, 0.0, 1.0], toward_eye)
    right /= np.linalg.norm(right)
    up = np.cross(toward_eye, right)
    return np.array([right, up, -toward_eye])


class _Projection:
    """World (N, 3) -> pixel (N, 2) and depth (N,), fitted so `points` fill the image."""

    def __init__(self, points: np.ndarray):
        self.axes = view_axes()
        screen = points @ self.axes[:2].T if len(points) else np.zeros((1, 2))
        low, high = np.percentile(screen, 0.5, axis=0), np.percentile(screen, 99.5, axis=0)  # stray points may fall off
        self.scale = min(
            (VIEW_WIDTH - 2 * MARGIN) / max(high[0] - low[0], 1e-9), (HEIGHT - 2 * MARGIN) / max(high[1] - low[1], 1e-9)
        )
        self.centre = (low + high) / 2

    def __call__(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        screen = (points @ self.axes[:2].T - self.centre) * self.scale
        pixels = np.column_stack([VIEW_WIDTH / 2 + screen[:, 0], HEIGHT / 2 - screen[:, 1]])
        return pixels, points @ self.axes[2]


@functools.lru_cache(maxsize=1)
def font():
    """Pillow's own font (no system font needed, so every machine draws the same pixels)."""
    from PIL import ImageFont

    return ImageFont.load_default(size=FONT_SIZE_PX)


def report_png(drawing: Drawing, record: dict, title: str) -> bytes:
    """The picture as PNG bytes; `record` is the path JSON document (its seams and warnings)."""
    from PIL import Image, ImageDraw

    everything = (
        np.vstack([drawing.scan_m, *(seam.positions_m for seam in drawing.seams)]) if drawing.seams else drawing.scan_m
    )
    project = _Projection(everything)
    canvas = np.full((HEIGHT, WIDTH, 3), 250, np.uint8)
    if len(drawing.scan_m):
        pixels, depth = project(drawing.scan_m)
        order = np.argsort(-depth, kind="stable")  # far first, so near points overwrite them
        xy, rgb = pixels[order].round().astype(int), colours(drawing.scan_values)[order]
        for dx in (0, 1):
            for dy in (0, 1):
                x, y = xy[:, 0] + dx, xy[:, 1] + dy
                inside = (x >= 0) & (x < VIEW_WIDTH) & (y >= 0) & (y < HEIGHT)
                canvas[y[inside], x[inside]] = rgb[inside]
    image = Image.fromarray(canvas)
    draw = ImageDraw.Draw(image)
    if len(drawing.candidates_m):
        for x, y in project(drawing.candidates_m)[0]:
            draw.point((x, y), fill=(0, 190, 255))
    for seam in drawing.seams:
        _draw_path(draw, project(seam.positions_m)[0], seam.pose_confidence)
        tails, heads = project(seam.arrow_tails_m)[0], project(seam.arrow_heads_m)[0]
        for tail, head in zip(tails, heads):
            draw.line([tuple(tail), tuple(head)], fill=(30, 30, 30), width=2)
        for (x, y), fill, name in zip(
            project(seam.positions_m[[0, -1]])[0], ((0, 160, 0), (208, 0, 0)), ("start", "end")
        ):
            draw.rectangle([x - 5, y - 5, x + 5, y + 5], fill=fill, outline=(0, 0, 0))
            draw.text((x + 8, y - 14), f"{seam.seam_id} {name}", fill=(0, 0, 0))
    draw.text((MARGIN, 10), title, fill=TEXT_RGB, font=font())
    _draw_legend(draw, drawing)
    _draw_panel(draw, record)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def _draw_path(draw, pixels: np.ndarray, confidence: np.ndarray) -> None:
    """The path through `pixels` (K, 2), each stretch between two poses in the colour of the less
    sure one, so an unsure pose shows on both sides of it."""
    if len(pixels) == 1:
        x, y = pixels[0]
        draw.ellipse([x - 2, y - 2, x + 2, y + 2], fill=tuple(confidence_colours(confidence)[0].tolist()))
        return
    # A dark rim under the whole path, so its pale (unsure) stretches stand out on any scan colour.
    draw.line([tuple(p) for p in pixels], fill=(40, 40, 40), width=8, joint="curve")
    rgb = confidence_colours(np.minimum(confidence[:-1], confidence[1:]))
    for start, end, colour in zip(pixels[:-1], pixels[1:], rgb.tolist()):
        draw.line([tuple(start), tuple(end)], fill=tuple(colour), width=5)


def _draw_legend(draw, drawing: Drawing) -> None:
    """Bottom left: what colours the scan, each seam's label, and the pose-confidence scale 0..1."""
    rows = [(f"scan coloured by {drawing.value_name}", (33, 145, 140))]
    rows += [(seam.label, PATH_RGB) for seam in drawing.seams]
    rows += [("pose confidence", None)] if drawing.seams else []
    width = max((24 if colour else 26 + CONFIDENCE_BAR_PX) + 7 * len(text) for text, colour in rows)
    draw.rectangle([MARGIN - 4, HEIGHT - MARGIN - 16 * len(rows) - 4, MARGIN + width, HEIGHT - MARGIN + 4],
                   fill=(255, 255, 255))  # fmt: skip
    for row, (text, colour) in enumerate(rows):
        y = HEIGHT - MARGIN - 16 * (len(rows) - row)
        if colour is not None:
            draw.rectangle([MARGIN, y + 2, MARGIN + 18, y + 10], fill=colour)
            draw.text((MARGIN + 24, y), text, fill=(0, 0, 0))
            continue
        # The scale: "0", a bar from white to the path's red, "1", then the name.
        draw.text((MARGIN, y), "0", fill=(0, 0, 0))
        left = MARGIN + 10
        for k, colour in enumerate(confidence_colours(np.linspace(0, 1, CONFIDENCE_BAR_PX)).tolist()):
            draw.line([(left + k, y + 2), (left + k, y + 10)], fill=tuple(colour))
        draw.rectangle([left - 1, y + 1, left + CONFIDENCE_BAR_PX, y + 11], outline=(120, 120, 120))
        draw.text((left + CONFIDENCE_BAR_PX + 4, y), "1", fill=(0, 0, 0))
        draw.text((left + CONFIDENCE_BAR_PX + 16, y), text, fill=(0, 0, 0))


def _draw_panel(draw, record: dict) -> None:
    """The seam table and the warnings in the panel right of the view; what does not fit is
    counted in a last line that says where the rest is."""
    left, right = VIEW_WIDTH + 16, WIDTH - 16
    draw.rectangle([VIEW_WIDTH, 0, WIDTH, HEIGHT], fill=PANEL_RGB)
    draw.line([VIEW_WIDTH, 0, VIEW_WIDTH, HEIGHT], fill=(200, 200, 200))
    bottom = HEIGHT - MARGIN
    y = MARGIN
    draw.text((left, y), "Seams", fill=TEXT_RGB, font=font())
    y += LINE_PX
    seams = record.get("seams", [])
    # A seam with unsure poses gets a second line: how many, and the lowest confidence.
    rows = [tuple(name for name, _ in SEAM_COLUMNS)] + [row for seam in seams for row in _seam_rows(seam)]
    # Leave room for the warnings heading and at least one warning line below the table.
    shown = _fitting(len(rows), (bottom - y) // LINE_PX - 3)
    for row in rows[:shown]:
        if isinstance(row, str):
            draw.text((left + JOINT_LEFT_PX, y), row, fill=TEXT_RGB, font=font())
        else:
            _draw_row(draw, left, y, row)
        y += LINE_PX
    if not seams:
        draw.text((left, y), "no seam found", fill=TEXT_RGB, font=font())
        y += LINE_PX
    elif shown < len(rows):
        left_out = sum(not isinstance(row, str) for row in rows[shown:])
        draw.text((left, y), f"... {left_out} more seam(s) in the HTML and the path JSON", fill=TEXT_RGB,
                  font=font())  # fmt: skip
        y += LINE_PX
    y += LINE_PX // 2
    draw.text((left, y), "Warnings", fill=TEXT_RGB, font=font())
    y += LINE_PX
    lines = [line for warning in record.get("warnings", []) for line in _wrapped(f"- {warning}", right - left)]
    lines = lines or ["none"]
    shown = _fitting(len(lines), (bottom - y) // LINE_PX)
    for line in lines[:shown]:
        draw.text((left, y), line, fill=TEXT_RGB, font=font())
        y += LINE_PX
    if shown < len(lines):
        draw.text((left, y), f"... {len(lines) - shown} more line(s) in the HTML and the path JSON", fill=TEXT_RGB,
                  font=font())  # fmt: skip


def _fitting(count: int, room: int) -> int:
    """How many of `count` lines to draw in `room` lines: all, or room - 1 and a line saying how many are left."""
    return count if count <= room else max(room - 1, 0)


def _seam_rows(seam: dict) -> list:
    """A seam's table row (cells), and a line of text when some of its poses are below 1."""
    cells = (
        str(seam.get("id")),
        str(seam.get("joint") or "unknown"),
        f"{seam.get('length_m', 0) * 1000:.1f}",
        str(len(seam.get("poses", []))),
        f"{seam.get('confidence', 0):.2f}",
        "yes" if seam.get("closed") else "no",
    )
    lowest, below = pose_summary(seam)
    return [cells, f"{below} pose(s) below confidence 1, lowest {lowest:.2f}"] if below else [cells]


def _draw_row(draw, left: int, y: int, cells: tuple[str, ...]) -> None:
    """One table row: the joint left-aligned, the other cells right-aligned on their column's edge."""
    for (name, edge), cell in zip(SEAM_COLUMNS, cells):
        if name == "joint":
            draw.text((left + JOINT_LEFT_PX, y), cell, fill=TEXT_RGB, font=font())
        else:
            draw.text((left + edge - round(draw.textlength(cell, font=font())), y), cell, fill=TEXT_RGB, font=font())


def _wrapped(text: str, width_px: int) -> list[str]:
    """`text` in lines no wider than width_px, broken between words, and inside a word too long for a line
    (a file path); the lines after the first are indented."""
    lines, line = [], ""
    for word in text.split():
        candidate = f"{line} {word}" if line else word
        if font().getlength(candidate) <= width_px:
            line = candidate
            continue
        if line:
            lines.append(line)
        line = f"  {word}"
        while font().getlength(line) > width_px:
            cut = max(k for k in range(4, len(line)) if font().getlength(line[:k]) <= width_px)
            lines.append(line[:cut])
            line = f"  {line[cut:]}"
    return [*lines, line]
