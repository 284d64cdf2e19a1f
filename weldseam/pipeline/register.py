"""Register: one point-to-plane ICP of several frames at once (merge.merge_frames explains it).

Each frame's smooth surface patches (Surface) are paired with the nearest patch of every other
frame; each step moves all frames but the first together to minimise the Tukey-weighted,
area-weighted point-to-plane distances, in the directions the pairs fix only, at a reach that
halves down to the finest.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from weldseam.geometry import transform_points
from weldseam.pipeline.patches import direction_cells

MAX_NORMAL_ANGLE_DEG = 20.0  # an ICP pair's two normals agree within this
TUKEY_C = 4.685  # Tukey's biweight constant, in robust standard deviations (1.4826 MAD)
MIN_SCALE_M = 0.0005  # the Tukey cut-off never drops below this (sensor noise scale)
# A direction of the joint motion is refined only if the pairs hold at least this much
# surface facing along it (summed over both members of every pair, so about half of it in
# one frame), beyond what normals tilted by NORMAL_NOISE would give.
MIN_FACING_AREA_M2 = 5e-5
NORMAL_NOISE = np.sin(np.radians(10.0))
CONVERGED_M = 3e-5  # an ICP step moving every paired point by less than this, at the finest reach, ends it
MAX_ITERATIONS = 60
EDGE_ACCURACY_M = 0.002  # edges place a frame along what planes leave open to about this (pixel footprints, mixed pixels, rounded corners)


class Surface(NamedTuple):
    """What ICP aligns in one frame (M samples): point (M, 3) on the patch plane, plane (M, 3)
    a point of that plane, normal (M, 3) unit toward the camera, area_m2 (M,) the patch's
    voxel face (its weight: a fine patch counts a quarter of a coarse one)."""

    point: np.ndarray
    plane: np.ndarray
    normal: np.ndarray
    area_m2: np.ndarray


class OpenMotions(NamedTuple):
    """The joint motions the pairs leave open: basis (6F, D) directions in the step's
    parameters (per free frame: rotation vector times lever, translation), about `centre` (3,)
    at `lever` (m); an empty basis when every direction is fixed."""

    basis: np.ndarray
    centre: np.ndarray
    lever: float


class Registration(NamedTuple):
    """corrections (K, 4, 4), overlap (K,), refined (K,), converged, undetermined (K,): as in
    MergedFrames; open_motions: what the pairs left open (None when nothing moved)."""

    corrections: np.ndarray
    overlap: np.ndarray
    refined: np.ndarray
    converged: bool
    undetermined: np.ndarray
    open_motions: OpenMotions | None = None


class _Step(NamedTuple):
    """One Gauss-Newton step: motions (F,) (4, 4), radius (m, the farthest paired point from
    the centre of rotation), open_dof (F,) how many open directions move each frame, open_motions."""

    motions: list
    radius_m: float
    open_dof: np.ndarray
    open_motions: OpenMotions


class _Aligned(NamedTuple):
    """What ICP aligns, per frame: sources (point, normal, area), targets (point, plane, normal)
    and a search tree over the target points."""

    sources: list
    targets: list
    trees: list


class _Pairs(NamedTuple):
    """Paired patches of one frame a (source) with another frame b (target), placed."""

    source: int
    target: int
    index: np.ndarray
    area_m2: np.ndarray
    points: np.ndarray
    residuals: np.ndarray
    normals: np.ndarray


def register(surfaces: list[Surface], reach_m: float, fine_m: float, min_overlap: float) -> Registration:
    """Joint point-to-plane ICP of all frames but the first (see merge_frames)."""
    count = len(surfaces)
    aligned = _aligned(surfaces)
    identity = np.tile(np.eye(4), (count, 1, 1))
    taking = np.ones(count, dtype=bool)
    overlap = _overlap(_pair(aligned, identity, taking, reach_m), aligned.sources)
    overlap[0] = 1.0
    taking = overlap >= min_overlap
    free = np.flatnonzero(taking[1:]) + 1
    if len(free) == 0:
        return Registration(identity, overlap, taking & False, True, np.zeros(count, dtype=int))
    settled = _settle(aligned, identity, taking, free, (reach_m, fine_m), None)
    if settled is None:
        return Registration(identity, overlap, np.zeros(count, dtype=bool), False, np.zeros(count, dtype=int))
    corrections, reach, last = settled
    final = _overlap(_pair(aligned, corrections, taking, reach), aligned.sources)
    overlap[free] = final[free]
    refined = np.zeros(count, dtype=bool)
    refined[free] = True
    undetermined = np.zeros(count, dtype=int)
    undetermined[free] = last.open_dof
    return Registration(corrections, overlap, refined, True, undetermined, last.open_motions)


def register_open(registration: Registration, edges: list[Surface], reach_m: float, fine_m: float) -> Registration:
    """Move the refined frames along the directions `registration` left open only, to align
    their `edges` (outline.outline_edges: each sample's normal is its face's outward direction
    across the edge) with every other frame's; directions the edges do not fix either stay as
    given. A frame the edges move by less than EDGE_ACCURACY_M keeps its pose: that is within
    where an edge can be placed (a pixel's footprint, a rounded corner). A registration whose
    edges do not settle is returned unchanged."""
    open_motions = registration.open_motions
    if open_motions is None or open_motions.basis.shape[1] == 0:
        return registration
    free = np.flatnonzero(registration.refined)
    taking = registration.refined.copy()
    taking[0] = True
    if any(len(e.point) == 0 for e, take in zip(edges, taking) if take):
        return registration
    settled = _settle(_aligned(edges), registration.corrections, taking, free, (reach_m, fine_m), open_motions)
    if settled is None:
        return registration
    corrections, _, last = settled
    for k in free:
        moved = transform_points(corrections[k], edges[k].point) - transform_points(registration.corrections[k], edges[k].point)
        if np.linalg.norm(moved, axis=1).max(initial=0.0) < EDGE_ACCURACY_M:
            corrections[k] = registration.corrections[k]
    undetermined = registration.undetermined.copy()
    undetermined[free] = last.open_dof
    return registration._replace(corrections=corrections, undetermined=undetermined, open_motions=last.open_motions)


def _aligned(surfaces: list[Surface]) -> _Aligned:
    """The frames' Surfaces as ICP reads them, each with a search tree."""
    targets = [(s.point, s.plane, s.normal) for s in surfaces]
    return _Aligned([(s.point, s.normal, s.area_m2) for s in surfaces], targets,
                    [cKDTree(point, balanced_tree=False) for point, _, _ in targets])


def _settle(aligned: _Aligned, start: np.ndarray, taking, free, reaches: tuple, open_motions):
    """Gauss-Newton steps of the `free` frames from corrections `start` (within `open_motions`
    when given) at a reach that halves from reaches[0] to reaches[1], until a step at the finest
    reach moves every paired point by less than CONVERGED_M: (corrections, reach, last _Step),
    None when it does not settle in MAX_ITERATIONS."""
    corrections = start.copy()
    reach, fine_m = reaches
    last = None
    for _ in range(MAX_ITERATIONS):
        step = _joint_step(_pair(aligned, corrections, taking, reach), free, reach, open_motions)
        if step is None:
            break
        last = step
        for k, motion in zip(free, step.motions):
            corrections[k] = motion @ corrections[k]
        step_m = max(np.linalg.norm(m[:3, :3] - np.eye(3), 2) * step.radius_m + np.linalg.norm(m[:3, 3])
                     for m in step.motions)
        if reach > fine_m:
            if step_m < 0.1 * reach:
                reach = max(fine_m, reach / 2)
        elif step_m < CONVERGED_M:
            return corrections, reach, last
    return None


def _pair(aligned: _Aligned, corrections, taking, reach_m) -> list[_Pairs]:
    """Every ordered pair of distinct frames that take part: each source patch of one with
    the nearest target patch of the other within `reach_m` whose normal agrees (both placed
    by `corrections`)."""
    min_cosine = np.cos(np.radians(MAX_NORMAL_ANGLE_DEG))
    sources, targets, trees = aligned
    pairs = []
    for a in np.flatnonzero(taking):
        point = transform_points(corrections[a], sources[a][0])
        normal = sources[a][1] @ corrections[a][:3, :3].T
        for b in np.flatnonzero(taking):
            if a == b:
                continue
            to_b = np.linalg.inv(corrections[b]) @ corrections[a]
            distance, nearest = trees[b].query(transform_points(to_b, sources[a][0]), distance_upper_bound=reach_m,
                                               workers=-1)
            found = np.flatnonzero(np.isfinite(distance))
            _, plane, target_normal = targets[b]
            target_normal = target_normal[nearest[found]] @ corrections[b][:3, :3].T
            agree = np.einsum("ij,ij->i", normal[found], target_normal) >= min_cosine
            found, target_normal = found[agree], target_normal[agree]
            residual = np.einsum("ij,ij->i", target_normal,
                                 point[found] - transform_points(corrections[b], plane[nearest[found]]))
            pairs.append(_Pairs(int(a), int(b), found, sources[a][2][found], point[found], residual, target_normal))
    return pairs


def _overlap(pairs: list[_Pairs], sources) -> np.ndarray:
    """(K,) share of each frame's source patches paired with any other frame."""
    paired = [np.zeros(len(point), dtype=bool) for point, _, _ in sources]
    for p in pairs:
        paired[p.source][p.index] = True
    return np.array([found.mean() if len(found) else 0.0 for found in paired])


def _joint_step(pairs: list[_Pairs], free: np.ndarray, reach_m: float, open_motions: OpenMotions | None):
    """One Gauss-Newton step of all `free` frames' motions (_Step), within `open_motions` when
    given (its centre and lever then parametrise the step); None when nothing is paired."""
    residual = np.concatenate([p.residuals for p in pairs]) if pairs else np.zeros(0)
    if len(residual) < 6:
        return None
    scales = _tukey_scales(residual, np.vstack([p.normals for p in pairs]), reach_m)
    points = np.vstack([p.points for p in pairs])
    if open_motions is None:
        centre = points.mean(axis=0)
        lever = np.sqrt(((points - centre) ** 2).sum(axis=1).mean())  # rotations in units of metres at this lever
    else:
        centre, lever = open_motions.centre, open_motions.lever
    width = 6 * len(free)
    column = {int(k): 6 * i for i, k in enumerate(free)}
    hessian, gradient = np.zeros((width, width)), np.zeros(width)
    rows = []
    for p, scale in zip(pairs, np.split(scales, np.cumsum([len(p.residuals) for p in pairs])[:-1])):
        weight = p.area_m2 * np.clip(1.0 - (p.residuals / scale) ** 2, 0.0, None) ** 2
        arm = (p.points - centre) / lever
        jacobian = np.hstack([np.cross(arm, p.normals), p.normals])
        # The pair's row of the joint Jacobian: +J in the source's columns, -J in the target's.
        selector = np.zeros((6, width))
        for u, sign in ((p.source, 1.0), (p.target, -1.0)):
            if u in column:
                selector[:, column[u]:column[u] + 6] += sign * np.eye(6)
        weighted = jacobian * weight[:, None]
        hessian += selector.T @ (weighted.T @ jacobian) @ selector
        gradient -= selector.T @ (weighted.T @ p.residuals)
        rows.append((arm, p.normals, weight, selector))
    if open_motions is None:
        curvature, directions = np.linalg.eigh(hessian)
    else:
        basis = open_motions.basis
        curvature, within = np.linalg.eigh(basis.T @ hessian @ basis)
        directions = basis @ within
    fixed = _information(rows, directions) >= MIN_FACING_AREA_M2
    step = directions[:, fixed] @ ((directions[:, fixed].T @ gradient) / curvature[fixed])
    # How many independent open directions move each frame: the rank of its block of the open
    # subspace, counting singular values whose square (the share of a direction) is a fifth or more.
    blocks = directions[:, ~fixed].reshape(len(free), 6, -1)
    open_dof = [int((np.linalg.svd(block, compute_uv=False) ** 2 >= 0.2).sum()) for block in blocks]
    motions = [_small_motion(part[:3] / lever, part[3:], centre) for part in step.reshape(len(free), 6)]
    radius = np.sqrt(((points - centre) ** 2).sum(axis=1).max())
    return _Step(motions, radius, np.array(open_dof), OpenMotions(directions[:, ~fixed], centre, lever))


def _information(rows: list, directions: np.ndarray) -> np.ndarray:
    """(D,) the information along each direction (columns of `directions`): per pair, the square
    of its normal's component along the motion's velocity u there, less what a normal tilted by
    noise would give (NORMAL_NOISE^2 |u|^2), weighted: many nearly level patches of a table must
    not add up to fixing a horizontal slide, nor the patches around a pipe a turn about its axis."""
    information = np.zeros(directions.shape[1])
    for arm, normals, weight, selector in rows:
        motion = selector @ directions  # (6, D): each direction's rotation and translation for this pair
        velocity = np.cross(motion[:3].T[None, :, :], arm[:, None, :]) + motion[3:].T[None, :, :]
        along = np.einsum("ndk,nk->nd", velocity, normals)
        information += weight @ np.maximum(along * along - NORMAL_NOISE**2 * (velocity * velocity).sum(axis=2), 0.0)
    return information


def _tukey_scales(residuals: np.ndarray, normals: np.ndarray, reach_m: float) -> np.ndarray:
    """(N,) Tukey cut-off of each pair: c = 4.685 x 1.4826 median |r| over the pairs facing the
    same way (patches.direction_cells), within [MIN_SCALE_M,
    reach_m]. A slide only a few faces or edges see (a box's ends) is not outvoted by the many
    that cannot see it (its top): their residuals would set a cut-off far below its offset."""
    cell = direction_cells(normals)
    order = np.argsort(cell, kind="stable")
    _, start, size = np.unique(cell[order], return_index=True, return_counts=True)
    medians = np.array([np.median(part) for part in np.split(np.abs(residuals[order]), start[1:])])
    sigma = np.empty(len(residuals))
    sigma[order] = np.repeat(1.4826 * medians, size)
    return np.clip(TUKEY_C * sigma, MIN_SCALE_M, reach_m)


def _small_motion(rotation_vector: np.ndarray, translation: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """(4, 4) rotation R = exp([w]x) about `centre` followed by `translation`: p -> R (p - c) + c + t."""
    from scipy.spatial.transform import Rotation

    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_rotvec(rotation_vector).as_matrix()
    matrix[:3, 3] = centre - matrix[:3, :3] @ centre + translation
    return matrix
