"""The pipeline's intermediate results a report overlays on the scan (descriptor, candidates)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from weldseam.config import PlanConfig
from weldseam.types import Scan


@dataclass(frozen=True)
class Overlay:
    """working_m (M, 3): the working cloud; descriptor (M,): its descriptor values;
    candidates_m (C, 3): the points segmented as seam candidates."""

    working_m: np.ndarray
    descriptor: np.ndarray
    candidates_m: np.ndarray


def scan_overlay(frames: Sequence[Scan], config: PlanConfig, *, source: str = "") -> Overlay:
    """Run the pipeline on the scans of one run (several are merged as `plan` merges them)
    with `config` and keep what the report shows."""
    from weldseam.pipeline.run import plan_frames, plan_paths

    stages: dict[str, tuple] = {}

    def keep(stage: str, points: np.ndarray, values) -> None:
        stages.setdefault(stage, (points, values))

    if len(frames) > 1:
        plan_frames(frames, config, source=source, dump=keep, allow_empty=True)
    else:
        plan_paths(frames[0], config, dump=keep, allow_empty=True)
    working, descriptor = stages["descriptor"]
    candidates = stages.get("segment", (np.empty((0, 3)), None))[0]
    return Overlay(working, descriptor, candidates)
