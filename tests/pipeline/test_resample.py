"""Resampling: even arc-length spacing, orthonormal frames with y = travel, smoothing that keeps shape."""

import numpy as np

from weldseam.geometry import unit
from weldseam.pipeline.resample import resample_flags, resample_seam
from weldseam.pipeline.section import PointFlag, pose_confidence


def line(step_m=0.0013, length_m=0.1):
    x = np.arange(0.0, length_m + 1e-12, step_m)
    return np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])


def circle(radius_m, count):
    """`count` points evenly round a circle of `radius_m` about the z axis in z = 0."""
    angles = np.linspace(0, 2 * np.pi, count, endpoint=False)
    return radius_m * np.column_stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)])


def test_a_straight_seam_gets_poses_every_spacing_on_the_line_with_travel_along_it():
    positions = line()
    axes = np.tile([0.0, 0.0, -1.0], (len(positions), 1))
    new, frames = resample_seam(positions, axes, spacing_m=0.002, smoothing_m=0.003, closed=False)
    assert np.allclose(np.linalg.norm(np.diff(new, axis=0), axis=1), positions[-1, 0] / (len(new) - 1))
    assert np.allclose(new[[0, -1]], positions[[0, -1]])
    assert np.allclose(new[:, 1:], 0.0)
    assert np.allclose(np.einsum("kij,kil->kjl", frames, frames), np.eye(3))  # orthonormal
    assert np.allclose(np.linalg.det(frames), 1.0)
    assert np.allclose(frames[:, :, 1], [1.0, 0.0, 0.0]) and np.allclose(frames[:, :, 2], [0.0, 0.0, -1.0])


def test_the_torch_axis_keeps_its_work_angle_and_loses_any_lean_along_the_seam():
    positions = line()
    work, lean = np.radians(5.0), np.radians(10.0)
    tilted = unit(np.array([np.sin(lean), np.sin(work), -np.cos(work) * np.cos(lean)]))
    _, frames = resample_seam(
        positions, np.tile(tilted, (len(positions), 1)), spacing_m=0.002, smoothing_m=0.003, closed=False
    )
    z = frames[:, :, 2]
    assert np.allclose(z[:, 0], 0.0, atol=1e-12)  # no component along the travel (x)
    assert np.allclose(np.arctan2(z[:, 1], -z[:, 2]), np.arctan2(tilted[1], -tilted[2]))  # work angle kept


def test_position_noise_does_not_tip_the_torch_axis():
    rng = np.random.default_rng(0)
    positions = line(0.002, 0.2) + np.column_stack([np.zeros(101), rng.normal(0, 2e-4, (101, 2))])
    axes = np.tile([0.0, 0.0, -1.0], (len(positions), 1))
    _, frames = resample_seam(positions, axes, spacing_m=0.002, smoothing_m=0.003, closed=False)
    tilt_deg = np.degrees(np.arccos(np.clip(-frames[:, 2, 2], -1, 1)))
    assert tilt_deg.mean() < 1.5 and tilt_deg.max() < 5.0


def test_a_closed_circle_stays_closed_and_round():
    radius = 0.05
    positions = circle(radius, 230)
    axes = np.tile([0.0, 0.0, -1.0], (len(positions), 1))
    new, frames = resample_seam(positions, axes, spacing_m=0.002, smoothing_m=0.003, closed=True)
    steps = np.linalg.norm(np.diff(np.vstack([new, new[:1]]), axis=0), axis=1)
    assert np.allclose(steps, steps.mean(), rtol=1e-3) and abs(steps.mean() - 0.002) < 1e-4
    # A Gaussian of sigma s shrinks a circle by about s^2 / (2 R): 0.09 mm here.
    assert np.abs(np.linalg.norm(new[:, :2], axis=1) - radius).max() < 0.00015
    tangents = np.column_stack([-np.sin(np.arctan2(new[:, 1], new[:, 0])), np.cos(np.arctan2(new[:, 1], new[:, 0]))])
    assert np.all(np.einsum("ij,ij->i", frames[:, :2, 1], tangents) > np.cos(np.radians(1.0)))


def test_each_pose_takes_the_flags_of_the_seam_points_around_it():
    positions = np.column_stack([np.arange(0.0, 0.02, 0.002), np.zeros(10), np.zeros(10)])
    flags = np.zeros(10, np.uint8)
    flags[4] = PointFlag.BRIDGED  # the point at 8 mm
    posed = resample_flags(positions, flags, spacing_m=0.001, closed=False)
    along = np.linspace(0.0, 0.018, len(posed))
    # the poses on the two segments that meet at it (one at the point before counts the segment after it)
    assert np.all((posed == PointFlag.BRIDGED) == ((along > 0.006 - 1e-9) & (along < 0.010 - 1e-9)))
    assert np.allclose(pose_confidence(posed), np.where(posed, 0.5, 1.0))


def test_a_pose_is_as_sure_as_the_least_sure_of_its_flags():
    both = np.array([PointFlag.ONE_FACE | PointFlag.INTERPOLATED, PointFlag.ROUGH, 0], np.uint8)
    assert pose_confidence(both).tolist() == [0.3, 0.6, 1.0]


def saddle_arc(start_rad, stop_rad, step_m, branch_m=0.026, main_m=0.05):
    """Points (K, 3) every ~step_m along a saddle curve (a vertical branch pipe of radius branch_m
    on a horizontal main pipe of radius main_m, axis x) and the torch axis there, minus the
    bisector of the two pipes' outward normals (K, 3): a curve that turns and rises at once."""
    angles = np.arange(start_rad, stop_rad, step_m / branch_m)
    y = branch_m * np.sin(angles)
    points = np.column_stack([branch_m * np.cos(angles), y, np.sqrt(main_m**2 - y**2)])
    branch = np.column_stack([np.cos(angles), np.sin(angles), np.zeros_like(y)])
    main = np.column_stack([np.zeros_like(y), y, points[:, 2]]) / main_m
    return points, -unit(branch + main)


def test_a_short_piece_of_a_3d_curve_keeps_its_torch_square_to_the_curve_to_its_ends():
    """Points a section apart (3 mm) over 25 mm where a saddle seam turns and rises, each with its
    true torch axis as a section measures it: square to the section's travel, which leaned along
    the torch by up to 10 degrees (the sections' travel comes from a rough chain). Squaring each
    axis to the path's travel again must give the true axis, ends included, where the path's
    travel has samples on one side only (a chord from them leans by up to 7 degrees; the
    quadratic's 3 at most come from the smoothing, which pulls the points beside a kept end point
    toward the curve's centre)."""
    rng = np.random.default_rng(3)
    positions, truth = saddle_arc(np.radians(25.0), np.radians(80.0), 0.003)
    tangent = unit(np.gradient(positions, axis=0))
    lean = np.radians(rng.uniform(-10.0, 10.0, len(positions)))[:, None]
    measured = np.cos(lean) * truth + np.sin(lean) * tangent
    new, frames = resample_seam(positions, measured, spacing_m=0.002, smoothing_m=0.003, closed=False)
    dense, dense_truth = saddle_arc(np.radians(25.0), np.radians(80.0), 0.0001)
    nearest = np.argmin(np.linalg.norm(new[:, None] - dense[None], axis=2), axis=1)
    error_deg = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", frames[:, :, 2], dense_truth[nearest]), -1, 1)))
    assert error_deg.mean() < 1.5 and error_deg.max() < 4.0  # a chord: 3.1 and 6.9


def test_scatter_in_depth_along_a_saddle_tilts_the_torch_less_than_over_the_positions_gaussian():
    """Sections 3 mm apart along a saddle curve (turning and rising, 25 mm branch radius), each
    point scattered 0.5 mm along its torch axis, each with its true axis. The axis is squared to the
    path's travel, so a travel tilted by the scatter tilts it: over the positions' 3 mm Gaussian
    by 2.1 degrees (mean over 20 draws); over twice that, which a 25 mm curve fills as a quadratic, by
    1.5."""
    rng = np.random.default_rng(5)
    dense, dense_truth = saddle_arc(np.radians(10.0), np.radians(170.0), 0.0001)
    errors = []
    for _ in range(20):
        positions, truth = saddle_arc(np.radians(10.0), np.radians(170.0), 0.003)
        positions = positions + rng.normal(0, 0.0005, (len(positions), 1)) * truth
        new, frames = resample_seam(positions, truth, spacing_m=0.002, smoothing_m=0.003, closed=False)
        nearest = np.argmin(np.linalg.norm(new[:, None] - dense[None], axis=2), axis=1)
        cosines = np.clip(np.einsum("ij,ij->i", frames[:, :, 2], dense_truth[nearest]), -1, 1)
        errors.append(np.degrees(np.arccos(cosines)).mean())
    assert np.mean(errors) < 1.8


def test_a_groove_over_a_blocks_edge_keeps_the_travel_of_each_face_close_to_the_edge():
    """A groove along a block's top turning 90 degrees down its face, a point every 3 mm. A
    quadratic over twice the positions' Gaussian cannot follow that turn: within 8-12 mm of the
    edge it would lean 10 degrees toward the other face; the travel there is fitted over the
    positions' Gaussian alone."""
    top = np.column_stack([np.arange(-0.06, 0.0, 0.003), np.zeros(20), np.zeros(20)])
    face = np.column_stack([np.zeros(20), np.zeros(20), -np.arange(0.003, 0.061, 0.003)])
    positions = np.vstack([top, [[0.0, 0.0, 0.0]], face])
    axes = np.vstack([np.tile([0.0, 0.0, -1.0], (20, 1)), [unit(np.array([-1.0, 0.0, -1.0]))],
                      np.tile([-1.0, 0.0, 0.0], (20, 1))])  # fmt: skip
    new, frames = resample_seam(positions, axes, spacing_m=0.002, smoothing_m=0.003, closed=False)
    on_top = new[:, 0] < new[:, 2]
    true_travel = np.where(on_top[:, None], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0])
    error_deg = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", frames[:, :, 1], true_travel), -1, 1)))
    from_edge = np.linalg.norm(new, axis=1)
    assert error_deg[(from_edge >= 0.008) & (from_edge < 0.012)].max() < 4.0
    assert error_deg[from_edge >= 0.012].max() < 2.0


def test_a_shallow_corners_bumps_across_are_smoothed_over_its_across_spread_and_its_axes_are_not():
    # A 150-degree valley's point moves 3.7 times farther across than its faces move in depth: bumps
    # of 1 mm across, 28 mm long, on a straight seam; its torch axis turns 20 degrees over 40 mm.
    positions = line(0.002, 0.2)
    positions[:, 1] = 0.001 * np.sin(2 * np.pi * positions[:, 0] / 0.028)
    turn = np.radians(20.0) * np.clip((positions[:, 0] - 0.08) / 0.04, 0.0, 1.0)
    axes = np.column_stack([np.zeros(len(turn)), np.sin(turn), -np.cos(turn)])
    plain, plain_frames = resample_seam(positions, axes, spacing_m=0.002, smoothing_m=0.003, closed=False)
    shallow, shallow_frames = resample_seam(positions, axes, spacing_m=0.002, smoothing_m=0.003, closed=False,
                                            across_spread=3.7)  # fmt: skip
    middle = slice(len(plain) // 5, -len(plain) // 5)  # a window's reach from the ends
    assert np.abs(shallow[middle, 1]).max() < 0.25 * np.abs(plain[middle, 1]).max()
    assert np.abs(plain[middle, 1]).max() > 0.0007  # a corner known as well across keeps them
    work = np.arctan2(shallow_frames[middle, 1, 2], -shallow_frames[middle, 2, 2])
    assert np.allclose(work, np.arctan2(plain_frames[middle, 1, 2], -plain_frames[middle, 2, 2]), atol=np.radians(0.5))


def test_a_shallow_corner_on_a_tight_curve_is_smoothed_no_wider_than_its_curve_allows():
    # A saddle's obtuse corner on a 30 mm curve: a wider Gaussian would cut the curve by s^2 / 2R.
    positions = circle(0.03, 95)
    axes = np.tile([0.0, 0.0, -1.0], (len(positions), 1))
    plain, _ = resample_seam(positions, axes, spacing_m=0.002, smoothing_m=0.003, closed=True)
    shallow, _ = resample_seam(positions, axes, spacing_m=0.002, smoothing_m=0.003, closed=True, across_spread=2.5)
    assert abs(np.linalg.norm(shallow[:, :2], axis=1).mean() - np.linalg.norm(plain[:, :2], axis=1).mean()) < 2e-5
