"""Which way a positive work angle turns the torch, by joint kind, whatever the travel direction.

A work angle a turns the torch about its travel direction (tool y): z' = cos(a) z + sin(a) x,
x = y cross z (shaping.with_work_angle). Welding a seam the other way flips y and so x: a sign
read off the tool frame would tilt the same seam to the other side. Here each seam's side is a
direction p in the robot base frame (z up, a floor-mounted arm): the torch turns toward p, the
rotation about y is +a when mean_k(x_k . p_k) > 0 and -a when it is < 0 (one sign per seam, so
a tilt never flips along a weld). p is the first reference of the kind's ladder with
|mean_k(x_k . p_k)| >= MIN_SIDE (sin 10 deg); nearer square to x, noise could flip the side.

References (robot base frame):
- down, -z. For a fillet or a lap this is "toward the lower face": in the section (x, z) the
  corner's two faces lie either side of the torch axis; the one on the +x side runs out from the
  corner along x - z, the other along -x - z (a fillet's bisector: both at 45 deg), so the +x face
  is the lower one exactly when x . up < 0, i.e. x . down > 0. Turning toward it raises the torch's
  angle from that face: a fillet's 45 deg becomes 45 + a from the bottom plate, a lap's split s
  (joints.lap_torch_split_deg, in the plan's axis) becomes s + a.
- away: horizontal, from the robot base's z axis toward the seam's middle (+x for a seam within
  1 mm of that axis): the plate farther from the robot.
- left: up cross away, the robot's left seen from its base.
- inside: from each pose toward the seam's centroid (a flat ring: its inside).
A straight seam always resolves within the first three (orthonormal, so one has |x . p| >= 0.57);
a seam whose across-axis turns all round even the fourth is refused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from weldseam.errors import InputError
from weldseam.types import JOINT_KINDS, WeldPath

MIN_SIDE = float(np.sin(np.radians(10.0)))
# A seam's middle nearer the robot base's z axis than this has no horizontal "away" of its own.
MIN_AWAY_M = 0.001
UP = np.array([0.0, 0.0, 1.0])
CORNER_LADDER = ("lower_face", "away_from_robot", "robot_left", "inside")
GROOVE_LADDER = ("away_from_robot", "robot_left", "down", "inside")
LADDERS = {kind: CORNER_LADDER if kind in ("fillet", "lap") else GROOVE_LADDER for kind in JOINT_KINDS}
SIDES = {
    "lower_face": "toward the lower face (the bottom plate)",
    "away_from_robot": "toward the side away from the robot",
    "robot_left": "toward the robot's left",
    "down": "downward",
    "inside": "toward the inside of the seam's curve",
}


@dataclass(frozen=True)
class WorkAngleRule:
    """The side a seam's work angle turns the torch to, and the rotation about tool y that does it.

    side: a key of SIDES, or None for a seam of unknown joint kind (then no work angle applies).
    rotation_deg: the signed rotation about the tool's y (travel) axis, degrees.
    """

    seam_id: int
    joint: str | None
    work_angle_deg: float
    side: str | None
    rotation_deg: float

    @property
    def fallback(self) -> bool:
        """The kind's first reference stood too near square to the torch's across-axis."""
        return self.side is not None and self.side != LADDERS[self.joint][0]

    def text(self) -> str:
        """One line, e.g. 'seam 0: fillet, work angle 10 deg toward the lower face (the bottom plate)'."""
        if self.side is None:
            if self.joint not in LADDERS:
                return f"seam {self.seam_id}: unknown joint kind, no work angle"
            return f"seam {self.seam_id}: {self.joint}, no work angle (its across-axis turns all round: no side)"
        why = ""
        if self.fallback:
            why = " (its faces stand level)" if self.joint in ("fillet", "lap") else " (the seam runs square to it)"
        added = ", added to the plan's split" if self.joint == "lap" and self.side == "lower_face" else ""
        return f"seam {self.seam_id}: {self.joint}, work angle {self.work_angle_deg:g} deg {SIDES[self.side]}{why}{added}"

    def to_dict(self) -> dict:
        """Plain JSON values."""
        return {"seam_id": self.seam_id, "joint": self.joint, "work_angle_deg": float(self.work_angle_deg),
                "side": self.side, "rotation_about_travel_deg": float(self.rotation_deg) + 0.0,
                "rule": self.text()}  # fmt: skip


def _away(positions_m: np.ndarray) -> np.ndarray:
    """(3,) horizontal unit vector from the robot base's z axis to the seam's middle (+x on the axis)."""
    middle = positions_m.mean(axis=0)
    horizontal = np.array([middle[0], middle[1], 0.0])
    length = np.linalg.norm(horizontal)
    return horizontal / length if length >= MIN_AWAY_M else np.array([1.0, 0.0, 0.0])


def _reference(side: str, positions_m: np.ndarray) -> np.ndarray:
    """(K, 3) or (3,) unit direction(s) the torch turns toward for `side`, robot base frame."""
    if side in ("lower_face", "down"):
        return -UP
    if side == "away_from_robot":
        return _away(positions_m)
    if side == "robot_left":
        return np.cross(UP, _away(positions_m))
    inward = positions_m.mean(axis=0) - positions_m
    return inward / np.maximum(np.linalg.norm(inward, axis=1, keepdims=True), 1e-12)


def work_angle_rule(path: WeldPath, work_angle_deg: float) -> WorkAngleRule:
    """The rule for `path` (already in the robot base frame): the first side of its kind's ladder
    with |mean(x . p)| >= MIN_SIDE, rotation = sign(mean(x . p)) * work_angle_deg.

    A seam of unknown kind (joint None or not in JOINT_KINDS) gets side None and no rotation; it
    is the caller's to refuse a non-zero angle there. When no side of the ladder stands clear of
    square to the seam's across-axis: side None for a zero angle, else InputError.
    """
    if path.joint not in LADDERS:
        return WorkAngleRule(path.seam_id, path.joint, work_angle_deg, None, 0.0)
    across = path.rotations[:, :, 0]
    for side in LADDERS[path.joint]:
        lean = float(np.mean(np.sum(across * _reference(side, path.positions_m), axis=-1)))
        if abs(lean) >= MIN_SIDE:
            return WorkAngleRule(path.seam_id, path.joint, work_angle_deg, side, float(np.sign(lean)) * work_angle_deg)
    if work_angle_deg == 0.0:
        return WorkAngleRule(path.seam_id, path.joint, work_angle_deg, None, 0.0)
    raise InputError(f"seam {path.seam_id} ({path.joint}): its across-axis turns all round, no side for the work "
                     "angle stands out; weld it with --work-angle-deg 0")  # fmt: skip
