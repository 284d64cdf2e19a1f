import numpy as np
import pytest

from tests.conftest import fillet_cloud, rotation_about, v_groove_cloud
from weldseam.config import PlanConfig
from weldseam.errors import NoSeamError
from weldseam.pipeline.run import STAGES, _line_valleys, plan_paths, run_steps
from weldseam.pipeline import segment
from weldseam.pipeline.valley_lines import band_width_m
from weldseam.synthetic.catalog import draw_case
from weldseam.synthetic.scenes import FAMILIES, make_scan
from weldseam.types import Scan

CONFIG = PlanConfig()


def plan(points, camera):
    return plan_paths(Scan(points_m=points, camera_origin_m=np.asarray(camera, float), source="test"), CONFIG)


def test_v_groove_path_lies_on_the_groove_centre_and_points_into_the_plate(rng):
    result = plan(v_groove_cloud(rng), [0.0, 0.05, 0.45])
    assert len(result.paths) == 1
    path = result.paths[0]
    assert path.joint == "v_groove" and not path.closed
    lateral = np.hypot(path.positions_m[:, 1], path.positions_m[:, 2] - 0.010)
    assert lateral.mean() < 0.0003 and lateral.max() < 0.001
    assert path.length_m > 0.22  # the groove is 0.24 m long: ends reached, no end caps
    torch = path.rotations[:, :, 2]
    assert np.degrees(np.arccos(-torch[:, 2])).max() < 2.0
    travel = path.rotations[:, :, 1]
    assert np.all(np.abs(travel[:, 0]) > 0.99)
    assert set(result.timings_s) == set(STAGES)


def test_a_groove_across_a_hole_in_the_scan_is_one_path_and_the_hole_is_reported(rng):
    points = v_groove_cloud(rng)
    hole = (points[:, 0] > 0.02) & (points[:, 0] < 0.055)  # 35 mm with no data, across the whole part
    result = plan(points[~hole], [0.0, 0.05, 0.45])
    assert len(result.paths) == 1
    path = result.paths[0]
    lateral = np.hypot(path.positions_m[:, 1], path.positions_m[:, 2] - 0.010)
    assert lateral.max() < 0.001 and path.length_m > 0.22
    (warning,) = result.warnings
    assert warning.startswith("seam 0: ") and "interpolated across a hole in the scan" in warning
    length_mm = float(warning.split(": ")[1].split(" mm")[0])
    middle_x = float(warning.split("around (")[1].split(",")[0])
    assert 30 <= length_mm <= 45 and abs(middle_x - 0.0375) < 0.005


def test_fillet_path_is_the_inside_corner_with_the_bisector_axis(rng):
    result = plan(fillet_cloud(rng), [0.0, 0.3, 0.3])
    assert [p.joint for p in result.paths] == ["fillet"]
    path = result.paths[0]
    corner_error = np.hypot(path.positions_m[:, 1], path.positions_m[:, 2])
    assert corner_error.mean() < 0.0005
    assert path.length_m > 0.18
    bisector = np.array([0.0, -1.0, -1.0]) / np.sqrt(2)
    angles = np.degrees(np.arccos(np.clip(path.rotations[:, :, 2] @ bisector, -1, 1)))
    assert angles.mean() < 3.0


def test_a_flat_plate_has_no_seam(rng):
    grid = np.stack(np.meshgrid(np.arange(0, 0.2, 0.0007), np.arange(0, 0.15, 0.0007)), -1).reshape(-1, 2)
    points = np.column_stack([grid, rng.normal(0, 0.0003, len(grid))])
    with pytest.raises(NoSeamError, match="no weld seam"):
        plan(points, [0.1, 0.07, 0.45])
    result = plan_paths(Scan(points_m=points, camera_origin_m=np.array([0.1, 0.07, 0.45])), CONFIG, allow_empty=True)
    assert result.paths == ()


def test_a_rigidly_moved_scan_gives_the_same_path_moved(rng):
    points = v_groove_cloud(rng)
    camera = np.array([0.0, 0.05, 0.45])
    rotation, shift = rotation_about([0.3, -0.2, 1.0], 0.9), np.array([0.4, -0.2, 0.1])
    original = plan(points, camera).paths[0]
    moved = plan(points @ rotation.T + shift, rotation @ camera + shift).paths[0]
    expected = original.positions_m @ rotation.T + shift
    # Compare as curves: each moved pose lies on the moved original path.
    from scipy.spatial import cKDTree

    distance, nearest = cKDTree(expected).query(moved.positions_m)
    assert np.median(distance) < 0.0005  # two noisy estimates, each within ~0.3 mm
    axes = np.einsum("ij,kj->ki", rotation, original.rotations[:, :, 2])[nearest]
    assert np.median(np.degrees(np.arccos(np.clip(np.sum(axes * moved.rotations[:, :, 2], 1), -1, 1)))) < 1.0


def test_same_input_gives_identical_paths(rng):
    points = v_groove_cloud(rng)
    first, second = plan(points, [0, 0.05, 0.45]), plan(points.copy(), [0, 0.05, 0.45])
    assert len(first.paths) == len(second.paths)
    for a, b in zip(first.paths, second.paths):
        assert np.array_equal(a.positions_m, b.positions_m) and np.array_equal(a.rotations, b.rotations)


def test_a_box_on_the_table_is_not_a_fillet_but_on_a_flange_it_is(rng):
    # The same corner geometry: resting on the table (the support plane) it is where a part
    # stands, not a joint; one flange thickness above the table it is a fillet.
    on_table = fillet_cloud(rng, flange_m=0.0)
    with pytest.raises(NoSeamError):
        plan(on_table, [0.0, 0.3, 0.3])
    assert [p.joint for p in plan(fillet_cloud(rng), [0.0, 0.3, 0.3]).paths] == ["fillet"]


def test_an_outside_corner_with_one_face_unseen_is_found_between_the_vs_edges(rng):
    """Two plates meet square at a convex ridge along x, their V's edges 2.5 mm either side of the
    seam (y = 0, z = 50 mm), the ridge's bisector up. The camera on face A's side (y < 0) sees A
    squarely and the V's far wall; face B (y > 0) faces it at 80 degrees of incidence and has no
    points. The seam is placed between the V's edges, the torch down the bisector, each pose saying
    one face was unseen."""
    root = np.sqrt(0.5)
    face = [(-0.0025 - root * s, -root * s) for s in np.arange(0.0, 0.045, 0.0005)]  # down-left from E_A
    wall = [(0.0025 * t, -0.004 + 0.004 * t) for t in np.linspace(0.0, 1.0, 9)]  # root up to E_B
    section = np.array(face + wall)
    x = np.arange(-0.08, 0.08, 0.0006)
    points = np.column_stack([np.repeat(x, len(section)), np.tile(section, (len(x), 1))])
    points[:, 2] += 0.05 + rng.normal(0.0, 0.0002, len(points))
    result = plan(points, [0.0, -0.25, 0.40])
    (path,) = result.paths
    assert path.joint == "outside_corner" and path.length_m > 0.15
    assert np.abs(path.positions_m[:, 1]).max() < 0.0005 and np.abs(path.positions_m[:, 2] - 0.05).max() < 0.0005
    assert np.degrees(np.arccos(-path.rotations[:, 2, 2])).max() < 2.0
    assert np.all(path.pose_confidence == 0.7)
    assert any("the unseen face is taken square to the seen one" in w for w in result.warnings)


def test_a_t_joint_seen_from_above_is_found_where_the_flange_ends_under_the_web(rng):
    """The camera looks down a T-joint's web: its face at y = 0 is seen edge-on (88 degrees of
    incidence) and has no points; the flange (z = 0, 0 < y < 80 mm) ends at its foot, the web's top
    is 50 mm up, the table 10 mm down beyond the flange. The seam is the corner y = 0, z = 0."""
    pitch = 0.0007
    x, y = (a.ravel() for a in np.meshgrid(np.arange(-0.1, 0.1, pitch), np.arange(-0.01, 0.1, pitch)))
    z = np.select([y < 0.0, y <= 0.08], [0.05, 0.0], -0.01)
    points = np.column_stack([x, y, z + rng.normal(0.0, 0.0003, len(x))])
    result = plan(points, [0.0, 0.01, 0.45])
    (path,) = result.paths
    assert path.joint == "fillet"
    inside = np.abs(path.positions_m[:, 0]) < 0.08
    assert inside.sum() > 60 and np.abs(path.positions_m[:, 0]).max() > 0.085  # the whole corner
    assert np.abs(path.positions_m[inside, 1]).max() < 0.0008 and np.abs(path.positions_m[inside, 2]).max() < 0.0008
    bisector = np.array([0.0, -1.0, -1.0]) / np.sqrt(2)
    assert np.degrees(np.arccos(path.rotations[inside, :, 2] @ bisector)).max() < 3.0
    assert any("one face of the corner was not seen" in w for w in result.warnings)
    assert np.mean(path.pose_confidence[inside] == 0.7) > 0.9  # each pose says its face was unseen


def test_valleys_along_their_length_are_not_sought_near_the_table():
    """Averaged along their length, the valley depths at the table (its noise far from the camera,
    the tubes' corners with it) show thousands of valleys on a broad valley scene; none of them is
    a candidate: nothing within descriptor.radius_m of the support plane is."""
    scene, scan = draw_case("valley", 0, broad=True)
    state = run_steps(Scan(points_m=scan.points_m, camera_origin_m=scan.camera_origin_m, source="test"), CONFIG,
                      last="segment")  # fmt: skip
    centre, normal = state.support
    near_table = np.abs((state.working - centre) @ normal) <= CONFIG.descriptor.radius_m
    selected = _line_valleys(state, CONFIG)
    assert selected.any() and not selected[near_table].any()
    state.support = None
    assert _line_valleys(state, CONFIG)[near_table].sum() > 1000


def test_a_band_as_wide_as_an_area_is_no_valley_along_its_length():
    """On a T-joint's plates the sensor's ripple leaves its troughs side by side: averaged along
    their length they select areas 19-47 mm wide (valley_lines.band_width_m), no valley's line."""
    rng = np.random.default_rng(0)
    scan = make_scan(FAMILIES["fillet_t"](rng), rng)
    state = run_steps(Scan(points_m=scan.points_m, camera_origin_m=scan.camera_origin_m, source="test"), CONFIG,
                      last="segment")  # fmt: skip
    found, _ = segment.cluster_candidates(state.working, _line_valleys(state, CONFIG),
                                          tolerance_m=CONFIG.segment.cluster_tolerance_m,
                                          min_length_m=CONFIG.segment.min_seam_length_m)  # fmt: skip
    widths = [band_width_m(state.working[members], CONFIG.condition.working_voxel_m) for members in found]
    assert max(widths) > 3 * CONFIG.descriptor.radius_m
    assert state.line_valleys == []


def test_no_planned_seam_runs_along_the_table():
    """Four sections of a corner at a part's foot on the table (rising 0.2-3.7 mm off it, so not
    on it by their median), extended along the table, gave a 94 mm "fillet" lying on it beside a
    V-groove and a square butt on a mount (broad scene, seed 83): the support rule is applied
    again to the seams as extended. The two welds stay."""
    scene, scan = draw_case("v_groove_and_square_butt", 83, broad=True)
    result = plan_paths(Scan(points_m=scan.points_m, camera_origin_m=scan.camera_origin_m, source="test"), CONFIG)
    heights = [np.median(path.positions_m[:, 2]) for path in result.paths]  # the table is z = 0
    assert min(heights) > 0.02
    assert sorted(path.joint for path in result.paths) == ["square_butt", "v_groove"]
