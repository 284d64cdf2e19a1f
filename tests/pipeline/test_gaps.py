from dataclasses import replace

import numpy as np
import pytest

from weldseam.config import PlanConfig
from weldseam.pipeline.gaps import gap_midpoints, image_directions, sensor_grid
from weldseam.pipeline.run import plan_paths
from weldseam.pipeline.segment import cluster_candidates
from weldseam.types import Scan

FOCAL_PX = 600.0


def look_at(camera, target, roll_rad):
    """Rows x, y, z of a camera frame looking from `camera` at `target`, rolled about its axis."""
    z = target - camera
    z /= np.linalg.norm(z)
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    c, s = np.cos(roll_rad), np.sin(roll_rad)
    return np.stack([c * x + s * y, -s * x + c * y, z])


def render_plates(camera, roll_rad, gap_m, rng, size_px=(480, 640), noise_m=0.0005, table_m=None, floor_m=None):
    """A pinhole sensor's points of two plates in z = 0 (|y| < 0.1, |x| < 0.08) with an opening
    |x - 0.01| < gap_m / 2 between them that returns nothing (a gap too narrow for a stereo
    match), or where `floor_m` is given, the floor that far below seen through it; depth noise
    along the rays; where `table_m` is given, a table that far below them (|x|, |y| < 0.2) seen
    around them."""
    frame = look_at(camera, np.zeros(3), roll_rad)
    rows, cols = np.mgrid[0:size_px[0], 0:size_px[1]]
    rays = np.column_stack([(cols.ravel() - size_px[1] / 2) / FOCAL_PX, (rows.ravel() - size_px[0] / 2) / FOCAL_PX,
                            np.ones(rows.size)]) @ frame
    hits = camera - (camera[2] / rays[:, 2])[:, None] * rays
    plates = (np.abs(hits[:, 0]) < 0.08) & (np.abs(hits[:, 1]) < 0.1)
    seen = plates & (np.abs(hits[:, 0] - 0.01) >= gap_m / 2)
    if floor_m is not None:
        through = camera - ((camera[2] + floor_m) / rays[:, 2])[:, None] * rays
        opening = plates & ~seen & (np.abs(through[:, 0] - 0.01) < gap_m / 2)
        hits[opening] = through[opening]
        seen |= opening
    if table_m is not None:
        below = camera - ((camera[2] + table_m) / rays[:, 2])[:, None] * rays
        table = ~plates & (np.abs(below[:, 0]) < 0.2) & (np.abs(below[:, 1]) < 0.2)
        hits[table] = below[table]
        seen |= table
    unit_rays = rays[seen] / np.linalg.norm(rays[seen], axis=1, keepdims=True)
    return hits[seen] + rng.normal(0.0, noise_m, (np.count_nonzero(seen), 1)) * unit_rays


def grid_of(camera, roll_deg):
    points = render_plates(camera, np.radians(roll_deg), 0.0, np.random.default_rng(0))
    return sensor_grid(image_directions(points, camera))


def quarter_turn_off(angle_deg: float) -> float:
    """How far an angle lies from a multiple of 90 degrees."""
    return abs((angle_deg + 45.0) % 90.0 - 45.0)


@pytest.mark.parametrize("roll_deg", [17.0, 40.0])
def test_the_sensor_grid_is_its_pixel_pitch_and_turns_with_its_roll(roll_deg):
    camera = np.array([0.05, -0.25, 0.45])
    pitch, angle = grid_of(camera, roll_deg)
    assert pitch == pytest.approx(1 / FOCAL_PX, rel=0.05)
    _, upright = grid_of(camera, 0.0)
    assert quarter_turn_off(np.degrees(angle - upright) - roll_deg) < 2.0


def test_a_cloud_with_no_pixel_grid_has_no_sensor_grid():
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(-0.1, 0.1, 50_000), rng.uniform(-0.1, 0.1, 50_000), np.zeros(50_000)])
    assert sensor_grid(image_directions(points, np.array([0.0, 0.0, 0.5]))) is None
    assert gap_midpoints(points, np.array([0.0, 0.0, 0.5]), max_width_m=0.004).shape == (0, 3)


@pytest.mark.parametrize("roll_deg, gap_m", [(0.0, 0.0015), (25.0, 0.0012), (62.0, 0.003)])
def test_the_middles_of_a_thin_gap_lie_in_it_along_its_length(roll_deg, gap_m):
    """Seen from 0.55 m, 30 degrees off the plate normal: a 1.2-3 mm opening is 1.5-4 pixels wide."""
    camera = np.array([0.0, -0.28, 0.47])
    points = render_plates(camera, np.radians(roll_deg), gap_m, np.random.default_rng(2))
    middles = gap_midpoints(points, camera, max_width_m=0.004)
    in_gap = np.abs(middles[:, 0] - 0.01) <= gap_m / 2 + 0.001
    assert np.count_nonzero(in_gap) >= 0.9 * len(middles)
    # Along the whole opening, a middle at least every 5 mm.
    along = np.sort(middles[in_gap, 1])
    assert along[0] < -0.09 and along[-1] > 0.09 and np.diff(along).max() < 0.005


@pytest.mark.parametrize("floor_m", [0.006, 0.05])
def test_an_opening_that_shows_the_floor_below_has_its_middles_too(floor_m):
    """Seen from straight above 0.45 m away, a 2.5 mm opening shows the floor 6 or 50 mm below
    (plates on a table, plates on a mount) through its 3-4 pixels: no pixel is missing, yet the
    points behind the plates' surface make the same crossings, middles along its length."""
    camera = np.array([0.01, -0.02, 0.45])
    points = render_plates(camera, np.radians(20.0), 0.0025, np.random.default_rng(4), floor_m=floor_m)
    middles = gap_midpoints(points, camera, max_width_m=0.004)
    in_gap = (np.abs(middles[:, 0] - 0.01) <= 0.0025 / 2 + 0.001) & (np.abs(middles[:, 2]) < 0.001)
    assert np.count_nonzero(in_gap) >= 0.9 * len(middles)
    along = np.sort(middles[in_gap, 1])
    assert along[0] < -0.09 and along[-1] > 0.09 and np.diff(along).max() < 0.005


@pytest.mark.parametrize("table_m", [0.004, 0.010])
def test_a_plate_edge_above_the_table_makes_no_line_of_middles(table_m):
    """The table 4 or 10 mm below the plates' outer edges lies behind them as a gap's floor does,
    but on one side only: a step down joins no two points of one surface. What noise lets through
    is scattered: no line of middles as long as a seam, which is what the candidates are."""
    camera = np.array([0.0, -0.28, 0.47])
    points = render_plates(camera, np.radians(25.0), 0.0, np.random.default_rng(6), table_m=table_m)
    middles = gap_midpoints(points, camera, max_width_m=0.004)
    config = PlanConfig().segment
    lines, _ = cluster_candidates(middles, np.ones(len(middles), bool), tolerance_m=config.cluster_tolerance_m,
                                  min_length_m=config.min_seam_length_m)
    assert len(middles) < 30 and not lines


def test_a_plate_without_an_opening_has_no_line_of_middles():
    camera = np.array([0.0, -0.28, 0.47])
    points = render_plates(camera, np.radians(25.0), 0.0, np.random.default_rng(3))
    assert len(gap_midpoints(points, camera, max_width_m=0.004)) < 10


@pytest.mark.parametrize(
    "gap_m, roll_deg, camera", [(0.0015, 25.0, (0.0, -0.3, 0.55)), (0.0012, 60.0, (0.1, -0.25, 0.5))]
)
def test_a_square_butt_seen_only_as_missing_pixels_is_planned(gap_m, roll_deg, camera):
    """Two plates on a table, their 1.2-1.5 mm opening returning nothing: it bends no surface,
    and only the gap candidates find it. The path runs the opening's length, within 0.5 mm of it."""
    camera = np.array(camera)
    points = render_plates(camera, np.radians(roll_deg), gap_m, np.random.default_rng(5), table_m=0.006)
    scan = Scan(points_m=points, camera_origin_m=camera, source="plates")
    (path,) = plan_paths(scan, PlanConfig(), allow_empty=True).paths
    assert path.joint == "square_butt"
    assert np.abs(path.positions_m[:, 0] - 0.01).max() < 0.0005 and np.abs(path.positions_m[:, 2]).max() < 0.0005
    assert path.positions_m[:, 1].min() < -0.095 and path.positions_m[:, 1].max() > 0.095
    without = replace(PlanConfig(), segment=replace(PlanConfig().segment, gaps=False))
    assert not plan_paths(scan, without, allow_empty=True).paths


def test_a_square_butt_on_a_mount_showing_the_floor_through_its_gap_is_planned():
    """Two plates on a mount 50 mm above the table, seen from nearly straight above 0.6 m away:
    every pixel of their 2.5 mm opening returns the table far below, none is missing, and nothing
    else finds it (the code before the points behind were counted planned nothing here). The path
    runs its length within 0.5 mm of it, a square butt."""
    camera = np.array([0.03, -0.08, 0.6])
    points = render_plates(camera, np.radians(20.0), 0.0025, np.random.default_rng(7), table_m=0.05, floor_m=0.05)
    scan = Scan(points_m=points, camera_origin_m=camera, source="mounted plates")
    (path,) = plan_paths(scan, PlanConfig(), allow_empty=True).paths
    assert path.joint == "square_butt"
    assert np.abs(path.positions_m[:, 0] - 0.01).max() < 0.0005 and np.abs(path.positions_m[:, 2]).max() < 0.0005
    assert path.positions_m[:, 1].min() < -0.095 and path.positions_m[:, 1].max() > 0.095


def test_directions_jittered_across_bin_edges_make_no_gaps():
    """A flat plate sampled on a 0.8 mm grid with 0.3 mm of depth noise, seen from straight above:
    its directions form a grid, jittered, and where a grid line sits on an edge between two lines
    of bins, its points fall into either; no run between them is a gap."""
    rng = np.random.default_rng(3)
    grid = np.stack(np.meshgrid(np.arange(0, 0.2, 0.0008), np.arange(0, 0.15, 0.0008)), -1).reshape(-1, 2)
    points = np.column_stack([grid, rng.normal(0, 0.0003, len(grid))])
    assert len(gap_midpoints(points, np.array([0.1, 0.07, 0.45]), max_width_m=0.004)) < 10
