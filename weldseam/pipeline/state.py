"""What the steps share: the PlanState each adds its results to, the bookkeeping of what became
of every candidate, and the timing of a step (run.py knows their order)."""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from weldseam import __version__
from weldseam.config import PlanConfig, config_to_dict
from weldseam.errors import StageError, WeldseamError
from weldseam.pipeline import candidates, normals, occlusion
from weldseam.pipeline.candidates import Candidate, Rejection
from weldseam.pipeline.neighbours import centroid_offsets, radius_graph
from weldseam.pipeline.section import FineSurface
from weldseam.types import Scan, WeldPath

Dump = Callable[[str, np.ndarray, np.ndarray | None], None]


class Source(NamedTuple):
    """How the probe and the trace treat a candidate's chains, by what found it: the joint kinds
    their sections seek (None: any), and when its pass's chains are traced: the fine passes'
    first (rank 0), the wide valleys' after them (1), the valleys found along their length last
    (2)."""

    kinds: frozenset | None = None
    rank: int = 0

    @property
    def follow_fits(self) -> bool:
        """Whether the chain may lie a few mm off its joint and is moved onto the seam points its
        sections find (a shallow valley's band, thinned over half its width: trace.on_fits), adding
        no seam points on a stretch traced before it: the shallow valleys' (rank above 0)."""
        return self.rank > 0


@dataclass
class PlanState:
    """What the steps have found so far (each step's fields are set by it; see STEPS)."""

    scan: Scan
    config: PlanConfig
    resources: ExitStack
    dump: Dump
    warnings: list[str] = field(default_factory=list)
    # condition
    camera: np.ndarray | None = None
    fine: np.ndarray | None = None
    fine_tree: object = None
    working: np.ndarray | None = None
    working_camera: np.ndarray | None = None
    view_points: np.ndarray | None = None  # a single view's valid raw points, until segment searches them
    graphs: dict = field(default_factory=dict)
    offsets_by_radius: dict = field(default_factory=dict)
    # normals, descriptor, segment, support
    normals: np.ndarray | None = None
    descriptor: np.ndarray | None = None
    valley: np.ndarray | None = None
    threshold: float | None = None
    valley_threshold: float | None = None
    clusters: list = field(default_factory=list)
    creases: list = field(default_factory=list)
    gaps: list = field(default_factory=list)
    wide_valleys: list = field(default_factory=list)
    line_valleys: list = field(default_factory=list)
    view: occlusion.ViewBuffer | None = None
    working_tree: object = None
    support: tuple | None = None
    # boundary, pairing, thinning, grid, order
    rims: list = field(default_factory=list)
    centre_points: list = field(default_factory=list)
    centre_sources: list = field(default_factory=list)  # a Source per centre_points entry
    chains: list = field(default_factory=list)
    chain_sources: list = field(default_factory=list)  # the Source of each chain
    # probe, trace, join, extend, split
    surface: FineSurface | None = None
    approx_axes: list = field(default_factory=list)
    probes: list = field(default_factory=list)
    seams: list = field(default_factory=list)
    holes: list = field(default_factory=list)
    short_candidates: list[Candidate] = field(default_factory=list)
    chain_candidates: list[Candidate] = field(default_factory=list)
    # resample
    paths: list[WeldPath] = field(default_factory=list)

    def candidate_points(self) -> np.ndarray:
        """(C, 3) the points of every candidate segment found: the descriptor's bands, the valleys
        and ridges, the wide valleys and those along their length (working points) and the lines
        of thin gaps (their middles)."""
        chosen = [*self.clusters, *self.creases, *self.wide_valleys, *self.line_valleys]
        parts = ([self.working[np.concatenate(chosen)]] if chosen else []) + list(self.gaps)
        return np.vstack(parts) if parts else np.empty((0, 3))

    def neighbourhoods(self, radius_m: float):
        """One radius graph of the working cloud per distinct radius: smoothing moves points by
        well under a voxel, so the neighbourhoods found before it still hold after it."""
        if radius_m not in self.graphs:
            self.graphs[radius_m] = radius_graph(self.working, radius_m)
        return self.graphs[radius_m]

    def centroid_offsets(self, radius_m: float) -> np.ndarray:
        """The working points' centroid_offsets over their neighbourhoods(radius_m), once per radius
        and working cloud (the valley depth and the occluded ends read the same ones; smoothing
        replaces the cloud, and offsets found before it are not reused)."""
        working, offsets = self.offsets_by_radius.get(radius_m, (None, None))
        if working is not self.working:
            offsets = centroid_offsets(self.neighbourhoods(radius_m), self.working)
            self.keep_centroid_offsets(radius_m, offsets)
        return offsets

    def keep_centroid_offsets(self, radius_m: float, offsets: np.ndarray) -> np.ndarray:
        """Remember `offsets`, computed elsewhere (the descriptor's pass: the occluded ends read them
        when boundary.radius_m is its radius), as the working points' centroid_offsets over
        neighbourhoods(radius_m); returns them."""
        self.offsets_by_radius[radius_m] = (self.working, offsets)
        return offsets


@contextmanager
def timed_step(name: str, timings: dict[str, float], on_stage: Callable[[str], None] | None):
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


def chain_candidate(state: PlanState, k: int, rejection: Rejection | None) -> Candidate:
    """The candidate chain k stands for, rejected for `rejection` (None: it became a seam)."""
    chain = state.chains[k]
    found = candidates.candidate_of(chain.points, chain.closed)
    if rejection is Rejection.NO_JOINT:  # what the middle probe found
        probes = state.probes[k]
        return replace(found, rejection=rejection, detail=probes[sorted(probes)[len(probes) // 2]].reason)
    return replace(found, rejection=rejection)


def reject_lost(state: PlanState, before, after, rejection: Rejection) -> None:
    """Mark the candidates that `before` traced and `after` no longer does as rejected so."""
    lost = set().union(*(s.sources for s in before)) - set().union(*(s.sources for s in after))
    for k in sorted(lost):
        state.chain_candidates[k] = replace(state.chain_candidates[k], rejection=rejection)


def dump_seams(state: PlanState, name: str) -> None:
    """Every seam's points, written under the step's name by --dump-stages."""
    for seam in state.seams:
        state.dump(name, seam.positions_m, None)


def run_record(state: PlanState, found: list[Candidate]) -> dict:
    """The run's record: version, input, camera origin, thresholds, every parameter and what
    became of every candidate (`found`)."""
    scan = state.scan
    return {
        "weldseam_version": __version__,
        "input": {"path": scan.source, "sha256": scan.sha256, "points": len(scan.points_m)},
        "camera_origin_m": normals.camera_record(state.camera),
        "threshold": float(state.threshold),
        "valley_threshold_m": None if state.valley_threshold is None else float(state.valley_threshold),
        "params": config_to_dict(state.config),
        "candidates": [c.as_record() for c in found],
    }
