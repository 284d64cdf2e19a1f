import io

import numpy as np
import pytest
from PIL import Image, ImageDraw

from weldseam.report.figure import confidence_colours, make_drawing
from weldseam.report.png import HEIGHT, PANEL_RGB, PATH_RGB, TEXT_RGB, VIEW_WIDTH, WIDTH, _Projection, font, report_png


def png_pixels(drawing, record) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(report_png(drawing, record, "plate"))).convert("RGB"))


def test_the_png_shows_the_scan_and_the_path_where_it_projects(plate_and_path):
    points, paths, record = plate_and_path
    drawing = make_drawing(points, paths, point_budget=20000)
    image = png_pixels(drawing, record).astype(int)
    assert image.shape == (HEIGHT, WIDTH, 3)
    assert image[:, :VIEW_WIDTH].std() > 20  # not blank
    project = _Projection(np.vstack([drawing.scan_m, paths[0].positions_m]))
    pixels, _ = project(paths[0].positions_m[5:-5])  # away from the start/end marks
    hits = 0
    for x, y in pixels.round().astype(int):
        window = image[y - 2 : y + 3, x - 2 : x + 3].reshape(-1, 3)
        hits += np.any(np.all(np.abs(window - PATH_RGB) <= 10, axis=1))
    assert hits >= 0.9 * len(pixels)


def test_the_png_is_deterministic(plate_and_path):
    points, paths, record = plate_and_path
    drawing = make_drawing(points, paths, point_budget=5000)
    assert report_png(drawing, record, "plate") == report_png(drawing, record, "plate")


def text_stamp(text: str) -> np.ndarray:
    """`text` as the PNG draws it (Pillow's font, black on the panel's white), cropped to its ink."""
    canvas = Image.new("RGB", (20 + int(font().getlength(text)), 40), PANEL_RGB)
    ImageDraw.Draw(canvas).text((10, 10), text, fill=TEXT_RGB, font=font())
    pixels = np.asarray(canvas)
    ink = np.argwhere(np.any(pixels != PANEL_RGB, axis=2))
    (top, left), (bottom, right) = ink.min(axis=0), ink.max(axis=0) + 1
    return pixels[top:bottom, left:right]


def panel_shows(panel: np.ndarray, text: str) -> bool:
    """Whether the exact pixels of `text` appear somewhere in the panel."""
    cv2 = pytest.importorskip("cv2")
    stamp = text_stamp(text)
    scores = cv2.matchTemplate(panel.astype(np.float32), stamp.astype(np.float32), cv2.TM_SQDIFF)
    y, x = np.unravel_index(scores.argmin(), scores.shape)  # the best match, then checked pixel for pixel
    return np.array_equal(panel[y : y + stamp.shape[0], x : x + stamp.shape[1]], stamp)


def test_the_png_has_the_html_panels_seam_table_and_warnings(plate_and_path):
    """It promised the same content as the HTML and had neither."""
    points, paths, record = plate_and_path
    record = {
        **record,
        "seams": [
            {"id": 0, "joint": "v_groove", "length_m": 0.16, "confidence": 0.9, "closed": False, "poses": [{}] * 81},
            {"id": 7, "joint": "fillet", "length_m": 0.4321, "confidence": 0.42, "closed": True, "poses": [{}] * 216},
        ],
        "warnings": ["no camera origin given: normals oriented toward +z", "a warning <b>escaped</b>"],
    }
    panel = png_pixels(make_drawing(points, paths, point_budget=2000), record)[:, VIEW_WIDTH:]
    for text in ("Seams", "length mm", "confidence", "closed", "v_groove", "160.0", "81", "0.90", "no",
                 "fillet", "432.1", "216", "0.42", "yes", "Warnings",
                 "- no camera origin given: normals oriented toward +z", "- a warning <b>escaped</b>"):  # fmt: skip
        assert panel_shows(panel, text), text
    assert not panel_shows(panel, "none")
    empty = png_pixels(make_drawing(points, paths, point_budget=2000), {**record, "warnings": []})[:, VIEW_WIDTH:]
    assert panel_shows(empty, "none")


def test_what_does_not_fit_in_the_png_says_where_it_is(plate_and_path):
    points, paths, record = plate_and_path
    seam = {"id": 1, "joint": "fillet", "length_m": 0.1, "confidence": 0.5, "closed": False, "poses": []}
    record = {**record, "seams": [seam] * 60, "warnings": ["/a/path/without/any/space/" * 8] * 40}
    panel = png_pixels(make_drawing(points, paths, point_budget=2000), record)[:, VIEW_WIDTH:]
    assert panel_shows(panel, "more seam(s) in the HTML and the path JSON")
    assert panel_shows(panel, "more line(s) in the HTML and the path JSON")


def test_the_png_colours_the_path_by_pose_confidence(unsure_path):
    """The interpolated stretch (0.3) is drawn in its own colour where it projects, the sure
    stretches stay in the path's red, and the legend carries the confidence scale."""
    points, path, record = unsure_path
    drawing = make_drawing(points, [path], point_budget=5000)
    image = png_pixels(drawing, record).astype(int)
    project = _Projection(np.vstack([drawing.scan_m, path.positions_m]))

    def share(poses, rgb):
        pixels = project(path.positions_m[poses])[0].round().astype(int)
        near = [np.any(np.all(np.abs(image[y - 2 : y + 3, x - 2 : x + 3] - rgb) <= 6, axis=2)) for x, y in pixels]
        return np.mean(near)

    unsure_rgb = confidence_colours(np.array([0.3]))[0]
    assert share(slice(22, 28), unsure_rgb) == 1 and share(slice(22, 28), PATH_RGB) == 0
    assert share(slice(35, 45), PATH_RGB) == 1 and share(slice(35, 45), unsure_rgb) == 0
    assert share(slice(51, 54), confidence_colours(np.array([0.7]))[0]) == 1
    legend = image[HEIGHT - 120 :, :400]
    scale = confidence_colours(np.linspace(0, 1, 5))[1:4]  # the bar's inner colours, not on the path
    assert all(np.all(np.abs(legend - rgb) <= 3, axis=2).any() for rgb in scale)


def test_the_png_panel_says_how_many_poses_are_unsure_and_the_lowest(unsure_path):
    points, path, record = unsure_path
    panel = png_pixels(make_drawing(points, [path], point_budget=2000), record)[:, VIEW_WIDTH:]
    assert panel_shows(panel, "15 pose(s) below confidence 1, lowest 0.30")
    sure = {**record, "seams": [{**record["seams"][0], "poses": [{}] * 81}]}
    assert not panel_shows(png_pixels(make_drawing(points, [path], point_budget=2000), sure)[:, VIEW_WIDTH:],
                           "below confidence 1")  # fmt: skip
