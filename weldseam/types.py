"""The few data types every part of weldseam shares.

Units are metres and radians. Arrays are float64. The base frame is the robot base; the
camera frame is OpenCV's (x right, y down, z forward).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from weldseam.errors import InputError
from weldseam.geometry import polyline_length


def as_points(array, name: str = "points") -> np.ndarray:
    """Return `array` as a C-contiguous float64 (N, 3) array, or raise InputError naming it."""
    points = np.ascontiguousarray(array, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"{name}: expected an (N, 3) array of x, y, z, got shape {points.shape}")
    return points


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of a depth camera; `depth_scale` = depth units per metre."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    depth_scale: float = 1000.0


FRAMES = ("base", "camera")
# The joint kinds a path's seam can name (weldseam.pipeline.joints.base.JointKind's values).
JOINT_KINDS = ("v_groove", "bevel", "square_butt", "fillet", "lap", "outside_corner")


@dataclass(frozen=True)
class Scan:
    """A point cloud in the base frame (or the camera frame, when nothing placed the camera),
    with where the camera was (to orient normals).

    points_m: (N, 3) points in metres, in `frame`.
    camera_origin_m: (3,) camera centre in that frame, or (N, 3) one per point (frames
        merged from several views: the camera that saw each point), or None when unknown.
    source: the file it came from ("-" for stdin), for messages and the output record.
    sha256: hex digest of the input bytes, recorded in the output.
    frame: "base" (the robot base) or "camera" (camera-frame data without a camera pose: a
        path planned on it is in the camera frame too).
    """

    points_m: np.ndarray
    camera_origin_m: np.ndarray | None = None
    source: str = ""
    sha256: str = ""
    frame: str = "base"


@dataclass(frozen=True)
class Tack:
    """A tack weld on a seam (part of it: the path runs across it): its middle on the seam line
    (m, the path's frame) and its length along the seam (m)."""

    middle_m: tuple[float, float, float]
    length_m: float

    def as_record(self) -> dict:
        """The tack for the JSON output."""
        return {"middle_m": list(self.middle_m), "length_m": self.length_m}


@dataclass(frozen=True)
class WeldPath:
    """One seam's ordered torch path.

    positions_m: (K, 3) base-frame points on the seam, in travel order.
    rotations: (K, 3, 3) tool frames; column 0 = x = y cross z, column 1 = y = travel
        direction, column 2 = z = torch axis pointing INTO the work.
    closed: the seam is a loop (the last pose joins the first).
    joint: the joint kind: "v_groove", "fillet", "lap", "square_butt", "bevel" or "outside_corner"
        (JOINT_KINDS); None when unknown (a path read from a CSV names none).
    confidence: 0..1, how sure the detector is that this is a weld seam.
    pose_confidence: (K,) 0..1 per pose, how sure its position and axis are (1: its cross-section
        fitted the joint; less where a face was unseen, a dropout bridged, a hole interpolated, or
        the fit was rough); None: all 1.
    tacks: the tack welds found on the seam, in travel order.
    """

    seam_id: int
    positions_m: np.ndarray
    rotations: np.ndarray
    closed: bool = False
    joint: str | None = None
    confidence: float = 1.0
    pose_confidence: np.ndarray | None = None
    tacks: tuple[Tack, ...] = ()

    @property
    def length_m(self) -> float:
        """Arc length along the poses (including the closing segment of a loop)."""
        return polyline_length(self.positions_m, self.closed)


@dataclass(frozen=True)
class RunResult:
    """What one `plan` run produced: the paths plus the record that reproduces them, every seam
    candidate with what became of it (pipeline.candidates.Candidate), and the working cloud with
    its descriptor values ((M, 3), (M,)), for a report."""

    paths: tuple[WeldPath, ...]
    record: dict = field(default_factory=dict)
    timings_s: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    candidates: tuple = ()
    descriptor: tuple | None = None
