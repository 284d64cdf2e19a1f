"""The support plane: the table the workpiece rests on, if the scan shows one, and the rule that
what a part forms with it is not a joint."""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.trace import TracedSeam

RANSAC_TRIALS = 200
COUNT_SAMPLE = 5000


def find_support_plane(
    points: np.ndarray, flat: np.ndarray, camera_origin_m: np.ndarray, *, tolerance_m: float, below_fraction: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """(point, unit normal toward the camera) of the support plane, or None.

    camera_origin_m: (3,), or (N, 3) one per point (merged frames: the camera that saw it).

    The largest plane through the `flat` points (RANSAC, fixed seed: deterministic) is
    the support when at most `below_fraction` of all points lie more than `tolerance_m`
    beyond it, away from the camera: everything else rests on it. A corner on that plane
    is where a part stands on the table, not a weld joint.
    """
    candidates = points[flat]
    if len(candidates) < 3:
        return None
    rng = np.random.default_rng(0)
    sample = candidates[rng.choice(len(candidates), min(COUNT_SAMPLE, len(candidates)), replace=False)]
    triples = candidates[rng.integers(0, len(candidates), (RANSAC_TRIALS, 3))]
    normals = np.cross(triples[:, 1] - triples[:, 0], triples[:, 2] - triples[:, 0])
    lengths = np.linalg.norm(normals, axis=1)
    valid = lengths > 1e-9
    normals, origins = normals[valid] / lengths[valid, None], triples[valid, 0]
    if len(normals) == 0:
        return None
    distances = np.abs(np.einsum("kj,nj->kn", normals, sample) - np.sum(normals * origins, axis=1)[:, None])
    best = int(np.argmax((distances <= tolerance_m).sum(axis=1)))
    on_plane = np.abs((candidates - origins[best]) @ normals[best]) <= tolerance_m
    inliers = candidates[on_plane]
    centre = inliers.mean(axis=0)
    normal = np.linalg.svd(inliers - centre, full_matrices=False)[2][2]
    cameras = np.asarray(camera_origin_m, dtype=np.float64)
    toward = (cameras[flat][on_plane] - inliers).sum(axis=0) if cameras.ndim == 2 else cameras - centre
    if normal @ toward < 0:
        normal = -normal
    beyond = (points - centre) @ normal < -tolerance_m
    return (centre, normal) if beyond.mean() <= below_fraction else None


def off_support(seams: list[TracedSeam], surface, support, tolerance_m: float) -> list[TracedSeam]:
    """The seams not formed with the support plane (`support` = (point, normal) or None): what a
    part forms with the table it rests on is not a joint, whatever its kind (a fillet where a part
    stands on the table, a V where a tilted plate's edge meets it). A seam is formed with it when,
    at most of its points (formed_with), the surface on one side of the seam is the table."""
    if support is None:
        return seams
    return [
        seam for seam in seams
        if not (lies_on(seam, support, tolerance_m) or formed_with(seam, surface, support, tolerance_m))
    ]


def lies_on(seam: TracedSeam, plane, tolerance_m: float) -> bool:
    """Whether a seam's points lie on `plane` (their median distance at most `tolerance_m`): an
    inside corner or a lap there is where a part stands or lies on the table, even where its side
    is hard to see; a groove's point lies at its plates' surface, and plates are thicker than the
    tolerance: an opening in the table itself (a slot, a crack, a line of missing pixels) is none."""
    centre, normal = plane
    return bool(np.median(np.abs((seam.positions_m - centre) @ normal)) <= tolerance_m)


def formed_with(seam: TracedSeam, surface, plane, tolerance_m: float) -> bool:
    """Whether at half or more of up to SIDE_SAMPLES points along the seam, SIDE_SHARE of the
    fine surface's points on one side of it (across it, SIDE_NEAR_M to SIDE_FAR_M from the seam
    line, within SIDE_SLAB_M along it) lie within tolerance_m / 2 of `plane` (point, unit normal).
    Distances are taken from the line, not across alone: where a corner's torch axis leans, a face
    lies partly under it, and a corner fitted 3.5 mm up a bar standing on the table, its axis
    level, has the table 3.5 mm below it and never 4 mm across."""
    centre, normal = plane
    positions, axes = seam.positions_m, seam.torch_axes
    travel = np.gradient(positions, axis=0) if len(positions) > 1 else np.zeros_like(positions)
    picks = seam.samples(SIDE_SAMPLES)
    touching = 0
    for k, members in zip(picks, surface.tree.query_ball_point(positions[picks], SIDE_FAR_M)):
        t = travel[k] / (np.linalg.norm(travel[k]) or 1.0)
        lateral = np.cross(t, axes[k])
        near = surface.points.take(members, axis=0)
        offsets = near - positions[k]
        across, along = offsets @ lateral, offsets @ t
        apart = np.linalg.norm(offsets - along[:, None] * t, axis=1)  # from the seam line
        on_plane = np.abs((near - centre) @ normal) <= tolerance_m / 2
        for side in (-1.0, 1.0):
            beside = (np.abs(along) <= SIDE_SLAB_M) & (side * across > 0) & (apart >= SIDE_NEAR_M)
            if np.count_nonzero(beside) >= 10 and np.mean(on_plane[beside]) >= SIDE_SHARE:
                touching += 1
                break
    return touching >= len(picks) / 2


# Sampling the surface beside a seam (formed_with).
SIDE_SAMPLES = 15
SIDE_NEAR_M = 0.004
SIDE_FAR_M = 0.016
SIDE_SLAB_M = 0.002
SIDE_SHARE = 0.6
