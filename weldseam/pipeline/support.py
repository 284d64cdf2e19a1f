"""The support plane: the table the workpiece rests on, if the scan shows one, and the rule that
what a part forms with it is not a joint."""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.joints import JointKind
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


def off_support(seams: list[TracedSeam], support, tolerance_m: float) -> list[TracedSeam]:
    """The seams that are not fillets on the support plane (`support` = (point, normal) or
    None): there a part stands on the table. A fillet lies on it when the median distance of its
    points from the plane is at most `tolerance_m`."""
    if support is None:
        return seams
    centre, normal = support
    return [
        seam
        for seam in seams
        if seam.joint != JointKind.FILLET or np.median(np.abs((seam.positions_m - centre) @ normal)) > tolerance_m
    ]
