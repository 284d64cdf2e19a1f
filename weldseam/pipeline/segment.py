"""Segmentation: threshold the descriptor automatically and cluster the seam candidates."""

from __future__ import annotations

import functools
import itertools

import numpy as np
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from weldseam.config import PlanConfig, SegmentConfig
from weldseam.geometry import principal_extent
from weldseam.pipeline.descriptor import gradient_descriptor, valley_depth
from weldseam.pipeline.grid import voxel_centroids, voxel_grid
from weldseam.pipeline.neighbours import centroid_offsets, neighbour_mean, radius_graph
from weldseam.pipeline.normals import orient_toward, pca_normals

# The wide valley pass works on voxel centroids this many times closer than its radius (about as
# many neighbours as the fine pass has at its own radius and spacing).
WIDE_NEIGHBOUR_SPACINGS = 2.5
# A point must lie this factor (far above rounding) times the tolerance outside a box to be left out (covered).
BOX_MARGIN = 1.000001


@functools.lru_cache(maxsize=64)
def automatic_threshold(
    *, spacing_m: float, normals_radius_m: float, descriptor_radius_m: float, variant: str, min_crease_deg: float
) -> float:
    """The descriptor value on the crease line of an ideal, noiseless crease of
    `min_crease_deg` (two half-planes), sampled at the working spacing and run through the
    same normal and descriptor code as the scan (`variant` "valley": the valley depth, m).

    A point passes when its surface bends at least as much as that crease does at its fold,
    so the rule is in physical terms (degrees), independent of noise level, point density
    and the descriptor variant, and needs no tuning per scan. A function of its parameters
    alone: remembered (three per run, the same for every scan of a batch).
    """
    half_extent = 3.0 * max(normals_radius_m, descriptor_radius_m)
    ticks = np.arange(-half_extent, half_extent + spacing_m / 2, spacing_m)
    u, v = np.meshgrid(ticks, ticks, indexing="ij")
    bend = np.radians(min_crease_deg)
    height = np.where(u > 0, u * np.tan(bend), 0.0)
    points = np.column_stack([u.ravel(), v.ravel(), height.ravel()])
    normals = pca_normals(points, radius_graph(points, normals_radius_m))
    normals *= np.where(normals[:, 2:3] < 0, -1.0, 1.0)
    graph = radius_graph(points, descriptor_radius_m)
    if variant == "valley":
        values = valley_depth(centroid_offsets(graph, points), normals)
    else:
        values = gradient_descriptor(normals, graph, variant=variant)
    on_fold = (np.abs(points[:, 0]) <= spacing_m / 2) & (np.abs(points[:, 1]) <= half_extent / 3)
    return float(np.median(values[on_fold]))


def crease_threshold(config: PlanConfig, variant: str, min_crease_deg: float | None = None) -> float:
    """automatic_threshold at a run's spacing (the working voxel) and radii, for `min_crease_deg`
    (None: segment.min_crease_deg)."""
    return automatic_threshold(
        spacing_m=config.condition.working_voxel_m, normals_radius_m=config.normals.radius_m,
        descriptor_radius_m=config.descriptor.radius_m, variant=variant,
        min_crease_deg=config.segment.min_crease_deg if min_crease_deg is None else min_crease_deg,
    )


def noise_floor(values: np.ndarray, factor: float) -> float:
    """`factor` x the robust standard deviation (1.4826 x the median absolute deviation) of a
    per-point measure over the scan: most of a scan is plane, where it is noise, so a crease must
    stand out of that noise to count (a rougher sensor or surface raises the bar)."""
    return factor * 1.4826 * float(np.median(np.abs(values - np.median(values))))


def dense_selection(graph, selected: np.ndarray, min_fraction: float) -> np.ndarray:
    """The selected points (N,) bool of which at least `min_fraction` of the neighbours (rows of
    `graph`) are selected too: a crease is a band of neighbouring points that all bend, noise
    exceeds a threshold at scattered points."""
    return selected & (neighbour_mean(graph, selected.astype(np.float64)) >= min_fraction)


def cluster_candidates(
    points: np.ndarray, selected: np.ndarray, *, tolerance_m: float, min_length_m: float
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Euclidean clusters of the selected points (indices into `points`): those whose longest
    extent (along their principal axis) reaches `min_length_m`, largest first, and those too
    short (extent at least `tolerance_m`: smaller specks are not candidates at all)."""
    indices = np.flatnonzero(selected)
    if len(indices) == 0:
        return [], []
    _, labels = connected_components(radius_graph(points[indices], tolerance_m), directed=False)
    order = np.argsort(labels, kind="stable")
    grouped = indices[order]
    starts = np.r_[0, np.flatnonzero(np.diff(labels[order])) + 1]
    groups = np.split(grouped, starts[1:])
    # A cluster whose bounding box's diagonal is under tolerance_m extends less than that along any
    # axis: a speck, dropped without its principal axis (most clusters are specks of noise).
    low, high = (reduce.reduceat(points[grouped], starts, axis=0) for reduce in (np.minimum, np.maximum))
    clusters, short = [], []
    for members in itertools.compress(groups, np.linalg.norm(high - low, axis=1) >= tolerance_m):
        extent = principal_extent(points[members])
        if extent >= min_length_m:
            clusters.append(members)
        elif extent >= tolerance_m:
            short.append(members)
    return sorted(clusters, key=lambda members: (-len(members), int(members[0]))), short


def wide_valleys(points: np.ndarray, camera: np.ndarray, *, radius_m: float, min_crease_deg: float,
                 noise_factor: float, min_density: float) -> np.ndarray:
    """(N,) bool: the points (N, 3) seen from `camera` ((3,) or (N, 3)) in a valley measured over
    `radius_m`: a valley between two tubes or curved plates, 120-160 degrees included and rounded
    at its bottom, is as deep over a few millimetres as a sensor's ripple, but stands out over a
    centimetre or two. Valley depth, its automatic threshold (the ideal crease of
    `min_crease_deg` at that scale), the noise floor and the density rule as in the fine pass,
    computed on the centroids of voxels radius_m / WIDE_NEIGHBOUR_SPACINGS wide; each point takes
    its voxel's answer (a centroid is seen from its first point's camera)."""
    spacing_m = radius_m / WIDE_NEIGHBOUR_SPACINGS
    coarse, voxel = voxel_grid(points, spacing_m)
    if len(coarse) < 3:
        return np.zeros(len(points), dtype=bool)
    camera = np.asarray(camera)
    if camera.ndim == 2:
        first = np.empty(len(coarse), np.intp)
        first[voxel[::-1]] = np.arange(len(points))[::-1]
        camera = camera[first]
    graph = radius_graph(coarse, radius_m)
    normals = orient_toward(pca_normals(coarse, graph), coarse, camera)
    depth = valley_depth(centroid_offsets(graph, coarse), normals)
    threshold = max(
        automatic_threshold(spacing_m=spacing_m, normals_radius_m=radius_m, descriptor_radius_m=radius_m,
                            variant="valley", min_crease_deg=min_crease_deg),
        noise_floor(depth, noise_factor),
    )
    selected = dense_selection(graph, depth > threshold, min_density)
    return selected[voxel]


def wide_valley_clusters(
    points: np.ndarray, camera: np.ndarray, fine_creases: list[np.ndarray], params: SegmentConfig
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """(clusters, too short) of the points (N, 3) seen from `camera` in a valley over
    params.wide_valley_radius_m (wide_valleys; cluster_candidates), but those one of the fine
    pass's valleys and ridges `fine_creases` covers (covered): a groove's bottom or a fillet's
    corner is not sought twice, a valley the fine pass saw only in scattered pieces is."""
    wide = wide_valleys(points, camera, radius_m=params.wide_valley_radius_m, min_crease_deg=params.min_crease_deg,
                        noise_factor=params.noise_factor, min_density=params.min_density)  # fmt: skip
    found, too_short = cluster_candidates(points, wide, tolerance_m=params.cluster_tolerance_m,
                                          min_length_m=params.min_seam_length_m)  # fmt: skip
    return uncovered(points, found, fine_creases, params.cluster_tolerance_m), too_short


def uncovered(points: np.ndarray, found: list[np.ndarray], known: list[np.ndarray], tolerance_m: float) -> list[np.ndarray]:
    """The clusters `found` that none of the `known` candidates covers (covered; both as indices
    into `points` (N, 3)): a crease another pass found is not sought twice."""
    trees = [cKDTree(points[candidate]) for candidate in known] if found else []
    return [members for members in found if not covered(points[members], trees, tolerance_m)]


def band_points(points: np.ndarray, params: SegmentConfig) -> np.ndarray:
    """A wide valley's band (N, 3) (or one found along its length: valley_lines) merged into voxels
    a quarter of params.wide_valley_radius_m wide:
    thinned over half that radius, its working points would each have ~50 neighbours, and its
    centre line is no finer than that anyway."""
    return voxel_centroids(points, params.wide_valley_radius_m / 4)


def covered(points: np.ndarray, candidates: list[cKDTree], tolerance_m: float, share: float = 0.5) -> bool:
    """Whether one of `candidates` (search trees over each candidate's points) lies within
    `tolerance_m` of at least `share` of `points` (M, 3). Only the points within that of a
    candidate's bounding box (on every axis) are searched: the others cannot count."""
    reach = tolerance_m * BOX_MARGIN
    for tree in candidates:
        near = np.all((points >= tree.mins - reach) & (points <= tree.maxes + reach), axis=1)
        if not near.any():
            continue
        distance = tree.query(points[near], distance_upper_bound=tolerance_m)[0]
        if np.count_nonzero(distance <= tolerance_m) / len(points) >= share:
            return True
    return False
