"""A static PNG of the report's view, drawn with Pillow (no browser): the scan as depth-sorted
splats coloured like the HTML, the paths, torch arrows and start/end marks on top."""

from __future__ import annotations

import io

import numpy as np

from weldseam.report.figure import Drawing, colours

WIDTH, HEIGHT, MARGIN = 1200, 800, 40
ELEVATION_DEG, AZIMUTH_DEG = 40.0, -60.0
PATH_RGB = ((230, 25, 75), (245, 130, 49), (255, 0, 255), (255, 69, 0), (220, 20, 60), (255, 105, 180))


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
            (WIDTH - 2 * MARGIN) / max(high[0] - low[0], 1e-9), (HEIGHT - 2 * MARGIN) / max(high[1] - low[1], 1e-9)
        )
        self.centre = (low + high) / 2

    def __call__(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        screen = (points @ self.axes[:2].T - self.centre) * self.scale
        pixels = np.column_stack([WIDTH / 2 + screen[:, 0], HEIGHT / 2 - screen[:, 1]])
        return pixels, points @ self.axes[2]


def report_png(drawing: Drawing, title: str) -> bytes:
    """The picture as PNG bytes."""
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
                inside = (x >= 0) & (x < WIDTH) & (y >= 0) & (y < HEIGHT)
                canvas[y[inside], x[inside]] = rgb[inside]
    image = Image.fromarray(canvas)
    draw = ImageDraw.Draw(image)
    if len(drawing.candidates_m):
        for x, y in project(drawing.candidates_m)[0]:
            draw.point((x, y), fill=(0, 190, 255))
    legend = [(f"scan coloured by {drawing.value_name}", (33, 145, 140))]
    for k, seam in enumerate(drawing.seams):
        colour = PATH_RGB[k % len(PATH_RGB)]
        line = [tuple(p) for p in project(seam.positions_m)[0]]
        draw.line(line, fill=colour, width=4, joint="curve")
        tails, heads = project(seam.arrow_tails_m)[0], project(seam.arrow_heads_m)[0]
        for tail, head in zip(tails, heads):
            draw.line([tuple(tail), tuple(head)], fill=(30, 30, 30), width=2)
        for (x, y), fill, name in zip(
            project(seam.positions_m[[0, -1]])[0], ((0, 160, 0), (208, 0, 0)), ("start", "end")
        ):
            draw.rectangle([x - 5, y - 5, x + 5, y + 5], fill=fill, outline=(0, 0, 0))
            draw.text((x + 8, y - 14), f"{seam.seam_id} {name}", fill=(0, 0, 0))
        legend.append((seam.label, colour))
    draw.text((MARGIN, 10), title, fill=(0, 0, 0))
    top = HEIGHT - MARGIN - 16 * len(legend) - 4
    draw.rectangle(
        [MARGIN - 4, top, MARGIN + 24 + 7 * max(len(text) for text, _ in legend), HEIGHT - MARGIN + 4],
        fill=(255, 255, 255),
    )
    for row, (text, colour) in enumerate(legend):
        y = HEIGHT - MARGIN - 16 * (len(legend) - row)
        draw.rectangle([MARGIN, y + 2, MARGIN + 18, y + 10], fill=colour)
        draw.text((MARGIN + 24, y), text, fill=(0, 0, 0))
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()
