import numpy as np
from scipy.spatial import cKDTree

from tests.conftest import fillet_cloud, v_groove_cloud
from weldseam.config import ExtendConfig, PlanConfig
from weldseam.pipeline.condition import condition_points
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.run import plan_paths
from weldseam.pipeline.section import FineSurface, section_params
from weldseam.pipeline.seek import Extension
from weldseam.pipeline.tacks import across_tack, points_over, tacks_of
from weldseam.types import Scan

THICKNESS = 0.010
DOWN = np.array([0.0, 0.0, -1.0])


def tacked_groove(rng, tacks, **kw):
    """v_groove_cloud (seam y = 0, z = 10 mm along x) with tack welds (centre x, length, height,
    m): the groove filled and a half-ellipsoid dome over it, as long as the tack, 1 mm wider
    than the opening each side."""
    points = v_groove_cloud(rng, gap_m=0.0, **kw)
    x, y = points[:, 0], points[:, 1]
    half_width = THICKNESS * np.tan(np.radians(35.0)) + 0.001
    for centre, length, height in tacks:
        inside = 1.0 - (2 * (x - centre) / length) ** 2 - (y / half_width) ** 2
        dome = THICKNESS + height * np.sqrt(np.clip(inside, 0.0, None)) + rng.normal(0.0, 0.0003, len(x))
        points[:, 2] = np.where(inside > 0, np.maximum(points[:, 2], dome), points[:, 2])
    return points


def seam_line(start_m=-0.1, end_m=0.1, spacing_m=0.002):
    xs = np.arange(start_m, end_m + spacing_m / 2, spacing_m)
    return np.column_stack([xs, np.zeros_like(xs), np.full_like(xs, THICKNESS)])


TACKS = [(-0.03, 0.008, 0.002), (0.04, 0.011, 0.0025)]


def test_each_tack_over_a_groove_is_found_where_it_sits_with_its_length(rng):
    points = tacked_groove(rng, TACKS)
    line = seam_line()
    found = tacks_of(line, points_over(line, np.tile(DOWN, (len(line), 1)), points, cKDTree(points)))
    assert len(found) == 2
    for tack, (centre, length, _) in zip(found, TACKS):
        assert np.linalg.norm(np.array(tack.middle_m) - [centre, 0.0, THICKNESS]) < 0.0015
        assert abs(tack.length_m - length) < 0.003
    plain = v_groove_cloud(rng)
    assert tacks_of(line, points_over(line, np.tile(DOWN, (len(line), 1)), plain, cKDTree(plain))) == ()


def test_an_inside_corner_is_no_tack_but_a_bead_in_it_is(rng):
    points = fillet_cloud(rng)  # corner y = 0, z = 0 along x; torch along the bisector
    line = np.column_stack([np.arange(-0.09, 0.09, 0.002), np.zeros(90), np.zeros(90)])
    axes = np.tile(np.array([0.0, -1.0, -1.0]) / np.sqrt(2), (len(line), 1))
    assert tacks_of(line, points_over(line, axes, points, cKDTree(points))) == ()
    angles = np.linspace(0.0, np.pi / 2, 12)
    xs = np.arange(0.015, 0.025, 0.0005)
    bead = np.array([[x, 0.003 * np.cos(a), 0.003 * np.sin(a)] for x in xs for a in angles])  # a 3 mm quarter round
    beaded = np.vstack([points[~((np.abs(points[:, 0] - 0.02) < 0.005) & (points[:, 1] < 0.003)
                                 & (points[:, 2] < 0.003))], bead])  # fmt: skip
    (tack,) = tacks_of(line, points_over(line, axes, beaded, cKDTree(beaded)))
    assert abs(tack.middle_m[0] - 0.02) < 0.0015 and abs(tack.length_m - 0.01) < 0.003


def test_an_extension_crosses_a_tack_on_the_seam_line_not_over_its_top(rng):
    fine = condition_points(tacked_groove(rng, [(0.0, 0.016, 0.003)]), voxel_m=0.001)
    surface = FineSurface(fine, cKDTree(fine), section_params(PlanConfig()))
    extension = Extension(surface, JointKind.V_GROOVE, ExtendConfig())
    last = np.array([-0.011, 0.0, THICKNESS])
    fits = across_tack(extension, last, DOWN, np.array([1.0, 0.0, 0.0]), np.zeros(3))
    bridged = np.array([f.point_m for f in fits if f.bridged])
    beyond = np.array([f.point_m for f in fits if not f.bridged])
    assert len(bridged) >= 6 and np.abs(bridged[:, 1:] - [0.0, THICKNESS]).max() < 0.0005
    assert len(beyond) == 2 and beyond[0, 0] > 0.008 and np.abs(beyond[:, 1:] - [0.0, THICKNESS]).max() < 0.0008
    plain = condition_points(v_groove_cloud(rng), voxel_m=0.001)
    extension = Extension(FineSurface(plain, cKDTree(plain), section_params(PlanConfig())), JointKind.V_GROOVE,
                          ExtendConfig())  # fmt: skip
    assert across_tack(extension, last, DOWN, np.array([1.0, 0.0, 0.0]), np.zeros(3)) is None


def test_a_tacked_groove_is_one_path_under_its_tacks_and_lists_them(rng):
    tacks = [(-0.06, 0.009, 0.002), (0.0, 0.012, 0.0025), (0.05, 0.007, 0.0018)]
    result = plan_paths(Scan(points_m=tacked_groove(rng, tacks), camera_origin_m=np.array([0.0, 0.05, 0.45])),
                        PlanConfig())  # fmt: skip
    (path,) = result.paths
    lateral = np.hypot(path.positions_m[:, 1], path.positions_m[:, 2] - THICKNESS)
    assert lateral.max() < 0.001 and path.length_m > 0.22
    assert len(path.tacks) == 3
    for tack, (centre, length, _) in zip(sorted(path.tacks, key=lambda t: t.middle_m[0]), tacks):
        assert abs(tack.middle_m[0] - centre) < 0.002 and abs(tack.length_m - length) < 0.004
