"""The pipeline's intermediate results a report overlays on the scan (descriptor, candidates)."""

from __future__ import annotations

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


def scan_overlay(scan: Scan, config: PlanConfig) -> Overlay:
    """Run the pipeline on `scan` with `config` and keep what the report shows."""
    from weldseam.pipeline.run import plan_paths

    stages: dict[str, tuple] = {}

    def keep(stage: str, points: np.ndarray, values) -> None:
        stages.setdefault(stage, (points, values))

    plan_paths(scan, config, dump=keep, allow_empty=True)
    working, descriptor = stages["descriptor"]
    candidates = stages.get("segment", (np.empty((0, 3)), None))[0]
    return Overlay(working, descriptor, candidates)
