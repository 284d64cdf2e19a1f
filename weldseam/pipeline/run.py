"""The pipeline: the only module that knows the order of the steps.

STEPS below is the whole chain, read top to bottom. Each step is a module of the same name
(weldseam/pipeline/NAME.py), whose parameters are the config section of that name where it has
any; it is timed under its name, its points are written under its name by --dump-stages, and its
tests are tests/pipeline/test_NAME.py. A step reads what the steps before it left in the
PlanState and adds its own results; a step that fails is reported with its name.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from weldseam.config import PlanConfig
from weldseam.errors import InputError, NoSeamError
from weldseam.geometry import polyline_length
from weldseam.pipeline import (
    across,
    apart,
    boundary,
    candidates,
    condition,
    descriptor,
    direction,
    extend,
    gaps,
    grid,
    join,
    nested,
    normals,
    occlusion,
    order,
    pairing,
    probe,
    resample,
    segment,
    smooth,
    slots,
    split,
    support,
    tacks,
    thinning,
    trace,
    valley_lines,
)
from weldseam.pipeline.candidates import Rejection
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.neighbours import pairs_among, pairs_graph, query_workers, radius_pairs
from weldseam.pipeline.parallel import in_background, worker_process
from weldseam.pipeline.section import FineSurface, PointFlag, pose_confidence, section_params
from weldseam.pipeline.state import (
    Dump, PlanState, Source, chain_candidate, dump_seams, reject_lost, run_record, timed_step,
)
from weldseam.types import RunResult, Scan, WeldPath

MIN_POINTS = 100
# A line of missing pixels between two surfaces is only a square butt's opening (gaps).
GAP_KINDS = frozenset({JointKind.SQUARE_BUTT})
# The fine tree answers the sections' 25 mm balls (~2000 points each): with big leaves and
# uncompacted nodes it is built in 33 ms instead of 58 and answers 600 balls in 107 ms, not 125.
FINE_TREE_LEAF_SIZE = 128


def _condition(state: PlanState, c: PlanConfig) -> None:
    """Finite points in the crop box merged into fine voxels (the surface the sections read) and
    working voxels (the neighbourhood steps), isolated working points dropped."""
    scan = state.scan
    valid = condition.valid_points(scan.points_m, crop_min_m=c.condition.crop_min_m, crop_max_m=c.condition.crop_max_m)
    if c.segment.gaps and scan.camera_origin_m is not None and np.shape(scan.camera_origin_m) == (3,):
        state.view_points = valid  # a single view's image, searched for thin gaps by _segment
    state.fine = grid.voxel_centroids(valid, c.condition.voxel_m)
    if len(state.fine) < MIN_POINTS:
        raise InputError(f"{scan.source}: only {len(state.fine)} valid points (finite, inside the crop box)")
    # The sections' search tree over the fine cloud is built on the other core meanwhile.
    state.fine_tree = in_background(
        cKDTree, state.fine, balanced_tree=False, compact_nodes=False, leafsize=FINE_TREE_LEAF_SIZE
    )
    working = grid.voxel_centroids(state.fine, c.condition.working_voxel_m)
    # Isolated points go before any neighbourhood statistics; their pairs go with them.
    pairs = radius_pairs(working, c.normals.radius_m)
    outliers = condition.sparse_points(pairs, len(working), min_fraction=c.condition.outlier_fraction)
    if outliers.any():
        pairs = pairs_among(pairs, ~outliers)
        working = working[~outliers]
    state.working = working
    state.graphs = {c.normals.radius_m: pairs_graph(pairs, len(working))}
    state.camera, state.working_camera = normals.camera_origins(scan, working, state.warnings)
    state.dump("condition", state.fine, None)


def _smooth(state: PlanState, c: PlanConfig) -> None:
    if c.smooth.enabled:
        state.working = smooth.smooth_points(state.working, state.neighbourhoods(c.smooth.radius_m),
                                             radius_m=c.smooth.radius_m, range_sigma_m=c.smooth.range_sigma_m)
    state.dump("smooth", state.working, None)


def _normals(state: PlanState, c: PlanConfig) -> None:
    graph = state.neighbourhoods(c.normals.radius_m)
    state.normals = normals.estimate_normals(state.working, graph, camera_origin_m=state.working_camera)


def _descriptor(state: PlanState, c: PlanConfig) -> None:
    """The published gradient descriptor (any bend, a band along a crease's edges), the signed valley depth."""
    radius = c.descriptor.radius_m
    state.descriptor, offsets = descriptor.descriptor_and_offsets(
        state.working, state.normals, state.neighbourhoods(radius), variant=c.descriptor.variant
    )
    state.valley = descriptor.valley_depth(state.keep_centroid_offsets(radius, offsets), state.normals)
    state.dump("descriptor", state.working, state.descriptor)


def _segment(state: PlanState, c: PlanConfig) -> None:
    """The candidates: bands where the descriptor exceeds the automatic threshold (or
    segment.threshold), and, apart from them, the valleys and the ridges where the signed bend
    exceeds its own (a groove's ridge never joins a plate's edge: on a narrow part the descriptor's
    bands merge), the valleys too shallow for that, over a wide reach or along their length
    (_line_valleys), and the lines of thin gaps in a single view's image (gaps; sought as square
    butts alone). Clusters too short are recorded as rejected. The table under the part (_support)
    is found here from the unbent points, before the valleys along their length (none lies on it)
    and before the worker forks (_probe): found after, its 8 MB of temporaries would land on pages
    shared with the worker, each then copied."""
    state.threshold = c.segment.threshold
    if state.threshold is None:
        state.threshold = segment.crease_threshold(c, c.descriptor.variant)
    state.clusters, short = _clusters(state, c, state.descriptor > state.threshold)
    if c.segment.valleys:
        state.valley_threshold = max(
            segment.crease_threshold(c, "valley"), segment.noise_floor(state.valley, c.segment.noise_factor)
        )
        graph = state.neighbourhoods(c.descriptor.radius_m)
        for side in (state.valley > state.valley_threshold, state.valley < -state.valley_threshold):
            found, too_short = _clusters(state, c, segment.dense_selection(graph, side, c.segment.min_density))
            state.creases += found
            short += too_short
    if c.support.enabled:
        state.support = support.find_support_plane(state.working, state.descriptor <= state.threshold,
                                                   state.working_camera, tolerance_m=c.support.tolerance_m,
                                                   below_fraction=c.support.below_fraction)  # fmt: skip
    if c.segment.valleys and c.segment.wide_valley_radius_m:
        state.wide_valleys, too_short = segment.wide_valley_clusters(state.working, state.working_camera,
                                                                     state.creases, c.segment)  # fmt: skip
        short += too_short
        if c.segment.line_valley_length_m:
            found, too_short = _clusters(state, c, _line_valleys(state, c))
            widest = valley_lines.MAX_BAND_WIDTH_RADII * c.descriptor.radius_m
            found = [members for members in found
                     if valley_lines.band_width_m(state.working[members], c.condition.working_voxel_m) <= widest]
            state.line_valleys = segment.uncovered(state.working, found, state.creases + state.wide_valleys,
                                                   c.segment.cluster_tolerance_m)  # fmt: skip
            short += too_short
    if c.segment.occluded_ends and state.scan.camera_origin_m is not None and state.camera.ndim == 1:
        # One camera: rims past whose end it sees a wall's top; the view buffer is kept for one_face.
        state.view = occlusion.ViewBuffer.build(state.fine, state.camera, c.condition.voxel_m)
        rims = occlusion.occluded_ends(state.working, state.normals, state.centroid_offsets(c.boundary.radius_m),
                                       state.view, c)  # fmt: skip
        found, too_short = _clusters(state, c, rims)
        state.creases += found
        short += too_short
    if state.view_points is not None:
        # Lines of the gaps' middles only: a round dropout's make a speck, which is no candidate.
        # Searched here, not while the fine tree is built on the other core: beside it, it took
        # twice as long.
        middles = gaps.gap_midpoints(state.view_points, state.camera, max_width_m=c.joints.gap_max_m)
        state.view_points = None
        found, _ = segment.cluster_candidates(middles, np.ones(len(middles), bool),
                                              tolerance_m=c.segment.cluster_tolerance_m,
                                              min_length_m=c.segment.min_seam_length_m)  # fmt: skip
        state.gaps = [middles[members] for members in found]
    state.short_candidates = [replace(candidates.cluster_candidate(state.working[members]), rejection=Rejection.TOO_SHORT)
                              for members in short]  # fmt: skip
    state.working_tree = cKDTree(state.working, balanced_tree=False, compact_nodes=False)
    state.dump("segment", state.candidate_points(), None)


def _line_valleys(state: PlanState, c: PlanConfig) -> np.ndarray:
    """(N,) bool: the working points whose valley depth, averaged along the valley over
    segment.line_valley_length_m (valley_lines), shows a bend of segment.line_valley_min_crease_deg,
    but those within descriptor.radius_m of the support plane (its corners with the parts on it,
    which that depth measures there, are no joints)."""
    depth = valley_lines.line_valley_depth(state.working, state.normals, state.valley,
                                           spacing_m=c.condition.working_voxel_m,
                                           length_m=c.segment.line_valley_length_m)  # fmt: skip
    selected = depth > segment.crease_threshold(c, "valley", c.segment.line_valley_min_crease_deg)
    if state.support is not None:
        centre, normal = state.support
        selected &= np.abs((state.working - centre) @ normal) > c.descriptor.radius_m
    return selected


def _clusters(state: PlanState, c: PlanConfig, selected: np.ndarray):
    return segment.cluster_candidates(state.working, selected, tolerance_m=c.segment.cluster_tolerance_m,
                                      min_length_m=c.segment.min_seam_length_m)


def _support(state: PlanState, c: PlanConfig) -> None:
    """The traced seams formed with the table under the part (the largest plane of unbent points
    that nothing lies beyond, found by _segment) dropped: there a part rests on the table."""
    state.seams = _off_support(state, c, state.seams)


def _off_support(state: PlanState, c: PlanConfig, seams: list) -> list:
    """`seams` but those formed with the table (support.off_support), their candidates marked so."""
    if not c.support.enabled:
        return seams
    kept = support.off_support(seams, state.surface, state.support, c.support.tolerance_m)
    reject_lost(state, seams, kept, Rejection.ON_SUPPORT)
    return kept


def _boundary(state: PlanState, c: PlanConfig) -> None:
    for members in state.clusters:
        band = state.working[members]
        rim = band[boundary.boundary_mask(
            band, state.normals[members], radius_m=c.boundary.radius_m, shift_ratio=c.boundary.shift_ratio
        )]
        state.rims.append(rim)
        state.dump("boundary", rim, None)


def _pairing(state: PlanState, c: PlanConfig) -> None:
    """Rim points paired across each descriptor band, their midpoints the candidate's centre points
    (the band itself where too narrow to pair); a valley or ridge band's points (a wide one's
    merged); a gap line's middles. Each with its Source (the kinds a gap's seek, a wide valley's
    chains moved onto their fits)."""
    for members, rim in zip(state.clusters, state.rims):
        in_cluster = np.zeros(len(state.working), dtype=bool)
        in_cluster[members] = True

        def in_band(points: np.ndarray, in_cluster=in_cluster) -> np.ndarray:
            return in_cluster[state.working_tree.query(points, workers=query_workers(len(points)))[1]]

        midpoints, _ = pairing.pair_midpoints(
            rim, tangent_radius_m=c.boundary.radius_m, angle_tolerance_deg=c.pairing.angle_tolerance_deg,
            max_width_m=c.pairing.max_width_m, width_tolerance=c.pairing.width_tolerance, in_band=in_band,
        )
        if len(midpoints) < 5:  # no rim pairs (a narrow band): thin the band itself
            midpoints = state.working[members]
        state.centre_points.append(midpoints)
        state.dump("pairing", midpoints, None)
    state.centre_points += [state.working[members] for members in state.creases]
    state.centre_points += state.gaps
    shallow = state.wide_valleys + state.line_valleys
    state.centre_points += [segment.band_points(state.working[members], c.segment) for members in shallow]
    state.centre_sources = ([Source()] * (len(state.clusters) + len(state.creases))
                            + [Source(GAP_KINDS)] * len(state.gaps)
                            + [Source(rank=1)] * len(state.wide_valleys)
                            + [Source(rank=2)] * len(state.line_valleys))  # fmt: skip


def _thinning(state: PlanState, c: PlanConfig) -> None:
    shallow = len(state.wide_valleys) + len(state.line_valleys)
    radii = [c.thinning.radius_m] * (len(state.centre_points) - shallow)  # all at once: thin_points
    radii += [c.segment.wide_valley_radius_m / 2] * shallow  # half a wide band's width (and so a line valley's)
    state.centre_points = thinning.thin_points(state.centre_points, radius_m=radii, iterations=c.thinning.iterations)
    for thinned in state.centre_points:
        state.dump("thinning", thinned, None)


def _grid(state: PlanState, c: PlanConfig) -> None:
    state.centre_points = [grid.voxel_centroids(thinned, c.grid.leaf_m) for thinned in state.centre_points]


def _order(state: PlanState, c: PlanConfig) -> None:
    for k, nodes in enumerate(state.centre_points):
        found = order.order_chains(nodes, link_m=c.order.link_m, min_branch_m=c.order.min_branch_m)
        state.chains += found
        state.chain_sources += [state.centre_sources[k]] * len(found)
    for chain in state.chains:
        state.dump("order", chain.points, None)


def _probe(state: PlanState, c: PlanConfig) -> None:
    """A few sections on every chain, seeking the kinds its source can show (a gap's: GAP_KINDS;
    the first step on the fine surface: the worker process that shares its sections starts here
    and stays until the run ends)."""
    openings = cKDTree(np.vstack(state.gaps)) if state.gaps else None
    state.surface = FineSurface(state.fine, state.fine_tree.result(), section_params(c), state.view, openings)
    state.resources.enter_context(worker_process(state.surface))
    state.approx_axes = probe.approximate_torch_axes(
        [chain.points for chain in state.chains], state.normals, state.working_tree, c.joints.face_radius_m
    )
    sought = [source.kinds for source in state.chain_sources]
    state.probes = probe.probe_chains(state.chains, state.approx_axes, state.surface, sought,
                                      min_length_m=c.grid.leaf_m, stretch_m=c.trace.max_gap_m)


def _trace(state: PlanState, c: PlanConfig) -> None:
    """The chains on the seams their probes find first (probe.tracing_order), pass by pass (Source.rank), each
    traced; a chain within face_radius / 2 of the opening of a groove traced before is skipped. The
    pieces are then taken in chain order."""
    chains, sources = state.chains, state.chain_sources
    by_length = sorted(range(len(chains)), key=lambda k: (sources[k].rank,
                                                          probe.tracing_order(chains[k], state.probes[k])))
    pieces: dict[int, list[trace.TracedSeam]] = {}
    traced_so_far: list[trace.TracedSeam] = []
    rejected: dict[int, Rejection] = {}
    for k in by_length:
        if polyline_length(chains[k].points, chains[k].closed) < c.grid.leaf_m:
            rejected[k] = Rejection.SHORT_CHAIN
        elif not any(fit.kind is not None for fit in state.probes[k].values()):
            rejected[k] = Rejection.NO_JOINT
        elif trace.inside_traced(chains[k].points, traced_so_far, c.joints.face_radius_m / 2):
            rejected[k] = Rejection.INSIDE_SEAM
        else:
            found = trace.trace_chain(chains[k], state.approx_axes[k], state.probes[k], state.surface, c.trace,
                                      follow_fits=sources[k].follow_fits, traced=traced_so_far,
                                      beside_m=c.joints.face_radius_m / 2)  # fmt: skip
            pieces[k] = [replace(seam, sources=frozenset({k})) for seam in found]
            traced_so_far += pieces[k]
            if not found:
                rejected[k] = Rejection.TOO_FEW_FITS
    state.seams = [seam for k in sorted(pieces) for seam in pieces[k]]
    state.chain_candidates = [chain_candidate(state, k, rejected.get(k)) for k in range(len(chains))]
    dump_seams(state, "trace")


def _join_traced(state: PlanState, c: PlanConfig) -> None:
    """The traced pieces joined, through a corner only within the extension's max_skip_m: the
    corner where two pieces' end lines meet misses the seam by their directions' error times the
    gap (a 4-point piece 21 mm below a block's edge: 2.6 mm), and the gap is left unsampled; an
    extension turns over the edge from its own fits (turn.py), and the pieces then meet."""
    state.seams = join.join_seams(state.seams, c.join, c.extend.step_m, corner_join_m=c.extend.max_skip_m)
    dump_seams(state, "join")


def _join(state: PlanState, c: PlanConfig) -> None:
    state.seams = join.join_seams(state.seams, c.join, c.extend.step_m)
    dump_seams(state, "join")


def _extend(state: PlanState, c: PlanConfig) -> None:
    seams = extend.extend_seams(state.seams, state.surface, c.extend)  # then pieces either side of a hole
    state.seams = across.join_across_holes(seams, state.surface, state.camera, c.extend, c.join.join_m)
    state.holes = [hole for seam in state.seams for hole in seam.holes]
    dump_seams(state, "extend")


def _split(state: PlanState, c: PlanConfig) -> None:
    """What lies inside a groove's opening is dropped first (it would split the groove), then the
    seams are split and checked (the support plane again: extended, a few sections of a corner at a
    part's foot run on along the table; slots, parts apart)."""
    own = nested.outside_grooves(state.seams)
    reject_lost(state, state.seams, own, Rejection.INSIDE_SEAM)
    final = split.split_seams(own, state.holes, c.split, c.extend.step_m)
    reject_lost(state, own, final, Rejection.FRAGMENT)
    final = _off_support(state, c, final)  # a few sections up a part's foot, extended along the table
    in_line = slots.in_line_seams(final, state.surface, c.section.half_width_m, state.support, c.support.tolerance_m)
    reject_lost(state, final, in_line, Rejection.SLOT)
    state.seams = apart.joined_seams(in_line, state.surface)
    reject_lost(state, in_line, state.seams, Rejection.APART)
    dump_seams(state, "split")


def _resample(state: PlanState, c: PlanConfig) -> None:
    """Poses every resample.spacing_m along each seam (a shallow corner's positions smoothed over
    more: its across_spread), each with its confidence; a warning for each hole crossed and for a
    corner with one face unseen."""
    spacing = c.resample.spacing_m
    for seam in state.seams:
        positions, rotations = resample.resample_seam(
            seam.positions_m, seam.torch_axes, spacing_m=spacing, smoothing_m=c.resample.smoothing_m,
            closed=seam.closed, across_spread=seam.across_spread,
        )
        flags = resample.resample_flags(seam.positions_m, seam.point_flags, spacing_m=spacing, closed=seam.closed)
        seam_id = len(state.paths)
        state.warnings += [resample.hole_warning(seam_id, hole) for hole in seam.holes]
        unseen = np.count_nonzero(flags & PointFlag.ONE_FACE) * spacing
        if unseen:
            state.warnings.append(resample.one_face_warning(seam_id, unseen, seam.joint))
        state.paths.append(WeldPath(
            seam_id=seam_id, positions_m=positions, rotations=rotations, closed=seam.closed,
            joint=seam.joint.value, confidence=seam.confidence, pose_confidence=pose_confidence(flags),
        ))
    state.chain_candidates = [
        replace(candidate, seam=next((k for k, seam in enumerate(state.seams) if index in seam.sources), None))
        if candidate.rejection is None else candidate
        for index, candidate in enumerate(state.chain_candidates)
    ]
    if state.paths:
        state.dump("resample", np.vstack([p.positions_m for p in state.paths]), None)


def _tacks(state: PlanState, c: PlanConfig) -> None:
    """Each path's tack welds: where material stands over its seam line (tacks.py)."""
    for k, path in enumerate(state.paths):
        over = tacks.points_over(path.positions_m, path.rotations[:, :, 2], state.fine, state.surface.tree)
        state.paths[k] = replace(path, tacks=tacks.tacks_of(path.positions_m, over))


def _direction(state: PlanState, c: PlanConfig) -> None:
    """Each path turned to travel by the user's rule (direction.py)."""
    state.paths = list(direction.orient_paths(state.paths, c.direction))


@dataclass(frozen=True)
class Step:
    name: str
    run: Callable[[PlanState, PlanConfig], None]


STEPS = (
    Step("condition", _condition),
    Step("smooth", _smooth),
    Step("normals", _normals),
    Step("descriptor", _descriptor),
    Step("segment", _segment),
    Step("boundary", _boundary),
    Step("pairing", _pairing),
    Step("thinning", _thinning),
    Step("grid", _grid),
    Step("order", _order),
    Step("probe", _probe),
    Step("trace", _trace),
    Step("support", _support),
    Step("join", _join_traced),
    Step("extend", _extend),
    Step("join", _join),  # extensions may meet
    Step("split", _split),
    Step("resample", _resample),
    Step("tacks", _tacks),
    Step("direction", _direction),
)
STAGES = tuple(dict.fromkeys(step.name for step in STEPS))  # the timing keys, in order


def run_steps(
    scan: Scan,
    config: PlanConfig,
    *,
    last: str | None = None,
    dump: Dump | None = None,
    on_stage: Callable[[str], None] | None = None,
    timings: dict[str, float] | None = None,
) -> PlanState:
    """The PlanState after running the steps on `scan`, up to and including the step named `last`
    (None: all of them), each timed into `timings`. What a step holds open (the worker process)
    is closed when this returns."""
    timings = {} if timings is None else timings
    with ExitStack() as resources:
        state = PlanState(scan, config, resources, dump or (lambda *_: None))
        for step in STEPS:
            with timed_step(step.name, timings, on_stage):
                step.run(state, config)
            if step.name == last:
                break
    return state


def plan_paths(
    scan: Scan,
    config: PlanConfig,
    *,
    dump: Dump | None = None,
    on_stage: Callable[[str], None] | None = None,
    allow_empty: bool = False,
) -> RunResult:
    """Run every step on `scan` and return the welding paths with the run's record.

    `dump(step, points, values)` receives each step's points (for --dump-stages);
    `on_stage(name)` is called as each step starts (for progress). Raises NoSeamError
    when nothing is found, unless `allow_empty`.
    """
    timings: dict[str, float] = {name: 0.0 for name in STAGES}
    state = run_steps(scan, config, dump=dump, on_stage=on_stage, timings=timings)
    found = [*state.short_candidates, *state.chain_candidates]
    if not state.paths and not allow_empty:
        raise NoSeamError(f"{scan.source or 'scan'}: no weld seam found ({candidates.why_none(found, config.segment)})",
                          tuple(found))
    record = run_record(state, found)
    return RunResult(paths=tuple(state.paths), record=record, timings_s=timings, warnings=tuple(state.warnings),
                     candidates=tuple(found), descriptor=(state.working, state.descriptor))  # fmt: skip


