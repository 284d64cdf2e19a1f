import io

import numpy as np
from PIL import Image

from weldseam.report.figure import make_drawing
from weldseam.report.png import PATH_RGB, _Projection, report_png


def test_the_png_shows_the_scan_and_the_path_where_it_projects(plate_and_path):
    points, paths, _ = plate_and_path
    drawing = make_drawing(points, paths, point_budget=20000)
    image = np.asarray(Image.open(io.BytesIO(report_png(drawing, "plate"))).convert("RGB")).astype(int)
    assert image.shape == (800, 1200, 3)
    assert image.std() > 20  # not blank
    project = _Projection(np.vstack([drawing.scan_m, paths[0].positions_m]))
    pixels, _ = project(paths[0].positions_m[5:-5])  # away from the start/end marks
    hits = 0
    for x, y in pixels.round().astype(int):
        window = image[y - 2 : y + 3, x - 2 : x + 3].reshape(-1, 3)
        hits += np.any(np.all(np.abs(window - PATH_RGB[0]) <= 10, axis=1))
    assert hits >= 0.9 * len(pixels)


def test_the_png_is_deterministic(plate_and_path):
    points, paths, _ = plate_and_path
    drawing = make_drawing(points, paths, point_budget=5000)
    assert report_png(drawing, "plate") == report_png(drawing, "plate")
