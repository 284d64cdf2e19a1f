"""The pipeline: the only module that knows the order of the stages.

Each stage is timed under its own name (the name of its module and config section); a
stage that fails is reported with that name.
"""

from __future__ import annotations

import hashlib
import itertools
import time
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from weldseam import __version__
from weldseam.config import PlanConfig, config_to_dict
from weldseam.errors import InputError, NoSeamError, StageError, WeldseamError
from weldseam.geometry import polyline_length, transform_points, unit
from weldseam.pipeline.assemble import assemble_seams
from weldseam.pipeline.boundary import boundary_mask
from weldseam.pipeline.condition import condition_points, sparse_points
from weldseam.pipeline.descriptor import gradient_descriptor
from weldseam.pipeline.grid import voxel_centroids
from weldseam.pipeline.merge import merge_frames, merge_warnings
from weldseam.pipeline.neighbours import pairs_among, pairs_graph, radius_graph, radius_pairs
from weldseam.pipeline.normals import estimate_normals
from weldseam.pipeline.order import order_chains
from weldseam.pipeline.pairing import pair_midpoints
from weldseam.pipeline.parallel import in_background, worker_process
from weldseam.pipeline.resample import resample_seam
from weldseam.pipeline.section import section_params
from weldseam.pipeline.segment import automatic_threshold, cluster_candidates
from weldseam.pipeline.smooth import smooth_points
from weldseam.pipeline.support import find_support_plane
from weldseam.pipeline.thinning import thin_points
from weldseam.pipeline.trace import TracedSeam, inside_traced, probe_chains, trace_chain
from weldseam.types import RunResult, Scan, WeldPath

STAGES = (
    "condition", "smooth", "normals", "descriptor", "segment", "boundary",
    "pairing", "thinning", "grid", "order", "section", "resample",
)
MIN_POINTS = 100
SUPPORT_TOLERANCE_M = 0.002  # how far a point may lie from the table plane and be on it
SUPPORT_BELOW_FRACTION = 0.05  # share of points allowed beyond the table (noise, outliers)
ORIGIN_SAMPLE = 200_000  # scan points searched for the camera that saw each working point
# The fine tree answers the sections' 25 mm balls (~2000 points each): with big leaves and
# uncompacted nodes it is built in 33 ms instead of 58 and answers 600 balls in 107 ms, not 125.
FINE_TREE_LEAF_SIZE = 128

Dump = Callable[[str, np.ndarray, np.ndarray | None], None]


@contextmanager
def _stage(name: str, timings: dict[str, float], on_stage: Callable[[str], None] | None):
    """Run one stage: announce it, add its time to timings[name], and turn a numerical failure
    inside it into a StageError that names it."""
    if on_stage:
        on_stage(name)
    start = time.perf_counter()
    try:
        yield
    except WeldseamError:
        raise
    except Exception as error:
        raise StageError(name, f"{type(error).__name__}: {error}") from error
    finally:
        timings[name] = timings.get(name, 0.0) + time.perf_counter() - start


def plan_paths(
    scan: Scan,
    config: PlanConfig,
    *,
    dump: Dump | None = None,
    on_stage: Callable[[str], None] | None = None,
    allow_empty: bool = False,
) -> RunResult:
    """Run every stage on `scan` and return the welding paths with the run's record.

    `dump(stage, points, values)` receives each stage's points (for --dump-stages);
    `on_stage(name)` is called as each stage starts (for progress). Raises NoSeamError
    when nothing is found, unless `allow_empty`.
    """
    timings: dict[str, float] = {name: 0.0 for name in STAGES}
    warnings: list[str] = []

    def stage(name: str):
        return _stage(name, timings, on_stage)

    def emit(name: str, points: np.ndarray, values: np.ndarray | None = None) -> None:
        if dump is not None:
            dump(name, points, values)

    camera = None if scan.camera_origin_m is None else np.asarray(scan.camera_origin_m, dtype=np.float64)
    if camera is None:
        finite = scan.points_m[np.isfinite(scan.points_m).all(axis=1)]
        camera = (finite.mean(axis=0) if len(finite) else np.zeros(3)) + np.array([0.0, 0.0, 1.0])
        warnings.append("no camera origin given: normals oriented toward +z (a camera above the part)")

    c = config
    with stage("condition"):
        fine = condition_points(
            scan.points_m, voxel_m=c.condition.voxel_m, crop_min_m=c.condition.crop_min_m,
            crop_max_m=c.condition.crop_max_m,
        )
        if len(fine) < MIN_POINTS:
            raise InputError(f"{scan.source}: only {len(fine)} valid points (finite, inside the crop box)")
        # The sections' search tree over the fine cloud is built on the other core meanwhile.
        fine_tree_building = in_background(
            cKDTree, fine, balanced_tree=False, compact_nodes=False, leafsize=FINE_TREE_LEAF_SIZE
        )
        working = voxel_centroids(fine, c.condition.working_voxel_m)
        # Isolated points go before any neighbourhood statistics; their pairs go with them.
        pairs = radius_pairs(working, c.normals.radius_m)
        outliers = sparse_points(pairs, len(working), min_fraction=c.condition.outlier_fraction)
        if outliers.any():
            pairs = pairs_among(pairs, ~outliers)
            working = working[~outliers]
        graphs = {c.normals.radius_m: pairs_graph(pairs, len(working))}
    emit("condition", fine)

    def neighbourhoods(radius_m: float):
        """One radius graph per distinct radius: smoothing moves points by well under a
        voxel, so the neighbourhoods found before it still hold after it."""
        if radius_m not in graphs:
            graphs[radius_m] = radius_graph(working, radius_m)
        return graphs[radius_m]

    working_camera = camera
    if camera.shape not in ((3,), scan.points_m.shape):
        raise InputError(f"{scan.source}: camera_origin_m must be (3,) or one (3,) per point, got {camera.shape}")
    if camera.ndim == 2:  # one origin per scan point (merged frames)
        with stage("merge"):
            working_camera = _nearest_origins(scan.points_m, camera, working)
    with stage("smooth"):
        if c.smooth.enabled:
            working = smooth_points(
                working, neighbourhoods(c.smooth.radius_m), radius_m=c.smooth.radius_m,
                range_sigma_m=c.smooth.range_sigma_m,
            )
    emit("smooth", working)
    with stage("normals"):
        normals = estimate_normals(working, neighbourhoods(c.normals.radius_m), camera_origin_m=working_camera)
    with stage("descriptor"):
        descriptor = gradient_descriptor(normals, neighbourhoods(c.descriptor.radius_m), variant=c.descriptor.variant)
    emit("descriptor", working, descriptor)
    with stage("segment"):
        threshold = c.segment.threshold
        if threshold is None:
            threshold = automatic_threshold(
                spacing_m=c.condition.working_voxel_m, normals_radius_m=c.normals.radius_m,
                descriptor_radius_m=c.descriptor.radius_m, variant=c.descriptor.variant,
                min_crease_deg=c.segment.min_crease_deg,
            )
        clusters = cluster_candidates(
            working, descriptor > threshold,
            tolerance_m=c.segment.cluster_tolerance_m, min_length_m=c.segment.min_seam_length_m,
        )
        support = None
        if c.section.ignore_support_corners:
            support = find_support_plane(
                working, descriptor <= threshold, working_camera, tolerance_m=SUPPORT_TOLERANCE_M,
                below_fraction=SUPPORT_BELOW_FRACTION,
            )
    emit("segment", working[np.concatenate(clusters)] if clusters else np.empty((0, 3)))
    working_tree = cKDTree(working)

    params = section_params(c.section, c.condition.voxel_m)
    centre_points = []  # per candidate, the points thinned onto its centre line
    for members in clusters:
        in_cluster = np.zeros(len(working), dtype=bool)
        in_cluster[members] = True

        def in_band(points: np.ndarray, in_cluster=in_cluster) -> np.ndarray:
            return in_cluster[working_tree.query(points, workers=-1)[1]]

        band, band_normals = working[members], normals[members]
        with stage("boundary"):
            rim = band[boundary_mask(
                band, band_normals, radius_m=c.boundary.radius_m, shift_ratio=c.boundary.shift_ratio
            )]
        emit("boundary", rim)
        with stage("pairing"):
            midpoints, _ = pair_midpoints(
                rim, tangent_radius_m=c.boundary.radius_m, angle_tolerance_deg=c.pairing.angle_tolerance_deg,
                max_width_m=c.pairing.max_width_m, width_tolerance=c.pairing.width_tolerance, in_band=in_band,
            )
            if len(midpoints) < 5:  # no rim pairs (a narrow band): thin the band itself
                midpoints = band
        emit("pairing", midpoints)
        centre_points.append(midpoints)
    with stage("thinning"):  # all candidates at once: see thin_points
        centre_points = thin_points(centre_points, radius_m=c.thinning.radius_m, iterations=c.thinning.iterations)
    chains = []
    for thinned in centre_points:
        emit("thinning", thinned)
        with stage("grid"):
            nodes = voxel_centroids(thinned, c.grid.leaf_m)
        with stage("order"):
            chains += order_chains(nodes, link_m=c.order.link_m, min_branch_m=c.order.min_branch_m)
    with stage("section"):
        fine_tree = fine_tree_building.result()
        with worker_process(fine, fine_tree):
            # Longest chains first; a chain within face_radius / 2 of the opening of a groove traced
            # before is skipped (fit_section takes that as the groove's reach). The pieces are then
            # taken in chain order, as found.
            by_length = sorted(range(len(chains)), key=lambda k: -polyline_length(chains[k].points))
            approx_axes = _approximate_torch_axes(
                [chain.points for chain in chains], normals, working_tree, c.section.face_radius_m
            )
            probes = probe_chains(chains, approx_axes, fine, fine_tree, params)
            pieces: dict[int, list[TracedSeam]] = {}
            traced_so_far: list[TracedSeam] = []
            for k in by_length:
                fitted = any(fit.joint for fit in probes[k].values())
                if not fitted or inside_traced(chains[k].points, traced_so_far, c.section.face_radius_m / 2):
                    continue
                pieces[k] = trace_chain(
                    chains[k], approx_axes[k], probes[k], fine, fine_tree,
                    step_m=c.resample.spacing_m, max_gap_m=c.section.max_gap_m,
                    min_valid_fraction=c.section.min_valid_fraction, section_params=params,
                )
                traced_so_far += pieces[k]
            traced = [seam for k in sorted(pieces) for seam in pieces[k]]
            seams = assemble_seams(
                traced, fine, fine_tree, support=support, support_tolerance_m=SUPPORT_TOLERANCE_M,
                overlap_m=c.order.overlap_m, join_m=c.order.join_m, max_turn_deg=c.order.max_join_turn_deg,
                min_branch_m=c.order.min_branch_m, min_seam_length_m=c.segment.min_seam_length_m,
                step_m=c.resample.spacing_m, max_gap_m=c.section.max_gap_m,
                max_extension_m=c.section.max_extension_m, max_hole_m=c.section.max_hole_m,
                section_params=params,
            )
    paths = []
    with stage("resample"):
        for seam in seams:
            positions, rotations = resample_seam(
                seam.positions_m, seam.torch_axes, spacing_m=c.resample.spacing_m,
                smoothing_m=c.resample.smoothing_m, closed=seam.closed,
            )
            warnings += [
                f"seam {len(paths)}: {hole.length_m * 1000:.0f} mm interpolated across a hole in the scan "
                f"(no data on the seam) around ({hole.middle_m[0]:.3f}, {hole.middle_m[1]:.3f}, "
                f"{hole.middle_m[2]:.3f}) m"
                for hole in seam.holes
            ]
            paths.append(
                WeldPath(
                    seam_id=len(paths), positions_m=positions, rotations=rotations,
                    closed=seam.closed, joint=seam.joint, confidence=seam.confidence,
                )
            )
    if paths:
        emit("path", np.vstack([p.positions_m for p in paths]))
    if not paths and not allow_empty:
        raise NoSeamError(f"{scan.source or 'scan'}: no weld seam found ({len(clusters)} candidate(s) rejected)")
    record = {
        "weldseam_version": __version__,
        "input": {"path": scan.source, "sha256": scan.sha256, "points": int(len(scan.points_m))},
        "camera_origin_m": np.round(_distinct_rows(camera), 9).tolist() if camera.ndim == 2
        else [round(float(v), 9) for v in camera],
        "threshold": float(threshold),
        "params": config_to_dict(config),
    }
    return RunResult(paths=tuple(paths), record=record, timings_s=timings, warnings=tuple(warnings))


def plan_frames(
    frames: Sequence[Scan],
    config: PlanConfig,
    *,
    source: str,
    dump: Dump | None = None,
    on_stage: Callable[[str], None] | None = None,
    allow_empty: bool = False,
) -> RunResult:
    """Merge several frames of one workpiece (each in the base frame with its (3,) camera
    origin) with `merge_frames`, then run `plan_paths` on the merged cloud. The record's
    input lists the frames with the ICP correction of each (how far it moved the frame's
    centroid, mm, and its rotation, degrees), whether it was refined and how many degrees of
    freedom its overlaps left open; `source` names the whole (the manifest, or the scans)."""
    from scipy.spatial.transform import Rotation

    if any(frame.camera_origin_m is None for frame in frames):
        raise InputError(f"{source}: every frame needs its pose to be merged with the others")
    m = config.merge
    spent: dict[str, float] = {}
    with _stage("merge", spent, on_stage):
        merged = merge_frames(
            [frame.points_m for frame in frames], np.array([frame.camera_origin_m for frame in frames]),
            dedup_voxel_m=m.dedup_voxel_m, icp_voxel_m=m.icp_voxel_m, icp_max_distance_m=m.icp_max_distance_m,
            min_overlap=m.min_overlap, max_incidence_deg=m.max_incidence_deg, refine=m.refine,
        )
    if dump is not None:
        dump("merge", merged.points_m, merged.frame.astype(np.float64))
    digest = hashlib.sha256("".join(frame.sha256 for frame in frames).encode()).hexdigest()
    scan = Scan(points_m=merged.points_m, camera_origin_m=merged.camera_origins_m, source=source, sha256=digest)
    result = plan_paths(scan, config, dump=dump, on_stage=on_stage, allow_empty=allow_empty)
    warnings = merge_warnings(merged, [frame.source for frame in frames], min_overlap=m.min_overlap, refine=m.refine)
    frames_record = [
        {
            "path": frame.source, "sha256": frame.sha256, "points": int(len(frame.points_m)),
            "kept_points": int((merged.frame == k).sum()),
            "icp_shift_mm": round(float(np.linalg.norm(transform_points(correction, centre) - centre)) * 1000, 6),
            "icp_rotation_deg": round(float(np.degrees(Rotation.from_matrix(correction[:3, :3]).magnitude())), 6),
            "icp_refined": bool(merged.refined[k]), "icp_open_dof": int(merged.undetermined[k]),
            "far_side_points": int(merged.far_side[k]),
        }
        for k, (frame, correction) in enumerate(zip(frames, merged.corrections))
        for centre in [np.nanmean(frame.points_m, axis=0, keepdims=True)]
    ]
    record = {**result.record, "input": {**result.record["input"], "frames": frames_record,
                                         "icp_converged": bool(merged.converged)}}
    timings = {"merge": spent["merge"] + result.timings_s.get("merge", 0.0)}
    timings.update((name, value) for name, value in result.timings_s.items() if name != "merge")
    return replace(
        result, record=record, timings_s=timings,
        warnings=(*warnings, *result.warnings),
    )


def _nearest_origins(points: np.ndarray, origins: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """(Q, 3) camera origin of the scan point nearest each query, among an even subsample of at
    most ORIGIN_SAMPLE finite points (merged frames own whole 3 mm voxels, so a point ~1 mm
    away belongs to a camera that saw the same surface; any such camera orients it)."""
    finite = np.flatnonzero(np.isfinite(points).all(axis=1))
    finite = finite[:: max(1, -(-len(finite) // ORIGIN_SAMPLE))]
    tree = cKDTree(points[finite], balanced_tree=False, compact_nodes=False)
    return origins[finite[tree.query(queries, workers=-1)[1]]]


def _distinct_rows(rows: np.ndarray) -> np.ndarray:
    """The rows of (N, 3) `rows` where they change from the previous row (runs collapsed), in order."""
    changes = np.r_[True, np.any(rows[1:] != rows[:-1], axis=1)]
    return rows[changes]


def _approximate_torch_axes(centres: list[np.ndarray], normals, tree, radius_m) -> list[np.ndarray]:
    """For each (K, 3) array of `centres`, the negated mean normal of the surface within
    `radius_m` of each centre: the plate normal beside a groove, the bisector of the faces at a
    corner; pointing into the work. One search for all (each search starts its own threads)."""
    if not centres:
        return []
    everywhere = np.concatenate(centres)
    neighbourhoods = tree.query_ball_point(everywhere, radius_m, workers=-1)
    counts = np.fromiter(map(len, neighbourhoods), np.intp, len(neighbourhoods))
    members = np.fromiter(itertools.chain.from_iterable(neighbourhoods), np.intp, counts.sum())
    owner = np.repeat(np.arange(len(everywhere)), counts)
    # bincount adds each centre's normals in member order, as a sum over them would.
    sums = np.column_stack([np.bincount(owner, normals[members, k], len(everywhere)) for k in range(3)])
    return np.split(unit(-sums), np.cumsum([len(c) for c in centres])[:-1])
