"""The record of every seam candidate: where it lies, how long it is, and what became of it."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from enum import Enum

import numpy as np

from weldseam.geometry import polyline_length, principal_extent


class Rejection(str, Enum):
    """Why a candidate did not become (part of) a seam."""

    TOO_SHORT = "shorter than segment.min_seam_length_m"
    SHORT_CHAIN = "too short to set its sections' direction (under grid.leaf_m)"
    NO_JOINT = "no joint model fits its sections"
    INSIDE_SEAM = "inside a seam traced before"
    TOO_FEW_FITS = "too few of its sections fit one joint (trace.min_valid_fraction)"
    ON_SUPPORT = "on the support plane, or formed with it (where a part rests on the table)"
    FRAGMENT = "too short after joining and extending"
    APART = "a corner between two parts standing apart (one face runs on behind the other: a clamp's post)"
    SLOT = "a slot between two parts (sides not in line, or a gap down to the table: a clamp or bar beside a part)"


@dataclass(frozen=True)
class Candidate:
    """A seam candidate: its centre (m), its length (m), the seam it became part of (None when
    rejected), the rejection, and the detail of why (e.g. what its sections found)."""

    centre_m: tuple[float, float, float]
    length_m: float
    seam: int | None = None
    rejection: Rejection | None = None
    detail: str = ""

    @property
    def outcome(self) -> str:
        """'seam N', or the reason it was rejected."""
        if self.seam is not None:
            return f"seam {self.seam}"
        return self.rejection.value + (f" ({self.detail})" if self.detail else "")

    def as_record(self) -> dict:
        """The candidate for the JSON record (mm and text)."""
        return {
            "centre_m": [round(v, 6) for v in self.centre_m], "length_m": round(self.length_m, 6),
            "seam": self.seam, "rejected": None if self.rejection is None else self.rejection.name.lower(),
            "reason": None if self.rejection is None else self.outcome,
        }


def candidate_of(points: np.ndarray, closed: bool = False) -> Candidate:
    """A Candidate at the middle point of ordered `points` (K, 3) with their length."""
    middle = points[len(points) // 2]
    return Candidate(tuple(round(float(v), 6) for v in middle), polyline_length(points, closed))


def cluster_candidate(points: np.ndarray) -> Candidate:
    """A Candidate for a cluster of working points: its mean and its extent along its principal axis."""
    centre = points.mean(axis=0)
    return Candidate(tuple(round(float(v), 6) for v in centre), principal_extent(points))


def commonest_reasons(candidates: list[Candidate], count: int = 3) -> str:
    """e.g. '4 no joint model fits its sections, 2 shorter than ...': the commonest rejections."""
    tally = Counter(c.rejection for c in candidates if c.rejection is not None)
    ranked = sorted(tally.items(), key=lambda item: (-item[1], item[0].name))[:count]
    return ", ".join(f"{n} {rejection.value}" for rejection, n in ranked)


def why_none(found: list[Candidate], segment) -> str:
    """Why a run found no seam, for its one error line: the commonest rejections of the
    candidates `found`, or, with none, that nothing bent enough (`segment`: SegmentConfig)."""
    rejected = [c for c in found if c.rejection is not None]
    if rejected:
        return f"{len(rejected)} candidate(s) rejected: {commonest_reasons(rejected)}"
    if segment.threshold is None:
        return f"nothing in the scan bends like a crease of segment.min_crease_deg ({segment.min_crease_deg:g} deg)"
    return f"nothing in the scan is above the descriptor threshold {segment.threshold:g}"
