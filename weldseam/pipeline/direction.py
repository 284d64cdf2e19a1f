"""Direction: every path runs by a rule the user can predict and set (`[direction]`, `--direction`).

Each rule gives a seam a reference direction d (a unit vector in the base frame):
- `+x`, `-x`, `+y`, `-y`, `+z`, `-z`: that base axis;
- `away-from-robot` / `toward-robot`: from / to the base origin through the seam's middle m;
- `start-point`: from the point `start_m` through the seam's middle.
An open seam runs along d: its chord c = end - start has c . d > 0. For the radial and point
rules that is the same as starting at the end nearer the base origin (or the point), since
|end|^2 - |start|^2 = 2 c . m with m the chord's middle. A closed seam turns counter-clockwise
seen from the tip of d (its vector area A = 1/2 sum p_i x p_i+1 has A . d > 0; `closed_sense`
"cw" the other way), and starts at its pose farthest back along d in its own plane, or with
`start-point` at its pose nearest the point.

A rule that cannot decide (a seam within TIE_DEG of square to d, a loop within TIE_DEG of
edge-on to it, or d within TIE_DEG of a loop's normal for its start) hands over to the next
direction of FALLBACKS: the other base axes in x, y, z order, with the rule's sign (`+` for
the radial and point rules, `-` for toward-robot). So a seam along y runs +y under the
default `+x`, and a decision never rests on a difference the noise of a scan could flip.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from weldseam.config import DirectionConfig
from weldseam.types import WeldPath

TIE_DEG = 10.0
_TIE = float(np.sin(np.radians(TIE_DEG)))
_AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}
_REVERSED_FRAME = np.array([-1.0, -1.0, 1.0])  # travel (y) and x = y cross z turn over, the torch axis stays


def orient_paths(paths: list[WeldPath], config: DirectionConfig) -> list[WeldPath]:
    """Every path of `paths` run by the rule of `config` (see the module docstring)."""
    return [orient_path(path, config) for path in paths]


def orient_path(path: WeldPath, config: DirectionConfig) -> WeldPath:
    """`path` reversed and (closed) rotated to start where the rule says; unchanged when it
    already runs so. Applying it twice changes nothing more."""
    positions = path.positions_m
    if len(positions) < 2:
        return path
    if not path.closed:
        chord = positions[-1] - positions[0]
        along = _decisive(_candidates(config, (positions[0] + positions[-1]) / 2), lambda d: chord @ d,
                          np.linalg.norm(chord))
        return path if along is None or chord @ along >= 0 else _reordered(path, np.arange(len(positions))[::-1], True)
    centred = positions - positions.mean(axis=0)
    area = 0.5 * np.cross(centred, np.roll(centred, -1, axis=0)).sum(axis=0)
    size = float(np.linalg.norm(area))
    candidates = _candidates(config, positions.mean(axis=0))
    about = _decisive(candidates, lambda d: area @ d, size)
    forward = about is None or (area @ about > 0) == (config.closed_sense == "ccw")
    if config.rule == "start-point":
        start = int(np.argmin(np.linalg.norm(positions - np.asarray(config.start_m), axis=1)))
    else:
        normal = area / size if size > 0 else np.zeros(3)
        back = _decisive(candidates, lambda d: np.linalg.norm(d - (d @ normal) * normal), 1.0)
        start = 0 if back is None else int(np.argmin(positions @ (back - (back @ normal) * normal)))
    steps = np.arange(len(positions))
    order = (start + steps) % len(positions) if forward else (start - steps) % len(positions)
    return path if np.array_equal(order, steps) else _reordered(path, order, not forward)


def _candidates(config: DirectionConfig, middle_m: np.ndarray) -> list[np.ndarray]:
    """The rule's reference direction for a seam whose middle is `middle_m`, then its fallbacks."""
    rule = config.rule
    if rule[0] in "+-":
        sign = 1.0 if rule[0] == "+" else -1.0
        return [sign * _AXES[rule[1]], *(sign * axis for name, axis in _AXES.items() if name != rule[1])]
    if rule == "start-point":
        first, sign = middle_m - np.asarray(config.start_m, dtype=np.float64), 1.0
    else:
        sign = 1.0 if rule == "away-from-robot" else -1.0
        first = sign * middle_m
    length = np.linalg.norm(first)
    head = [first / length] if length > 0 else []
    return [*head, *(sign * axis for axis in _AXES.values())]


def _decisive(candidates: list[np.ndarray], measure, scale: float) -> np.ndarray | None:
    """The first candidate d whose |measure(d)| reaches sin(TIE_DEG) * scale, or None."""
    return next((d for d in candidates if abs(measure(d)) >= _TIE * scale and scale > 0), None)


def _reordered(path: WeldPath, order: np.ndarray, reverse: bool) -> WeldPath:
    """The path's poses in `order`; `reverse`: travelling the other way (y and x turn over)."""
    rotations = path.rotations[order] * _REVERSED_FRAME if reverse else path.rotations[order]
    confidence = None if path.pose_confidence is None else path.pose_confidence[order]
    tacks = path.tacks[::-1] if reverse else path.tacks
    return replace(path, positions_m=path.positions_m[order], rotations=rotations, pose_confidence=confidence,
                   tacks=tacks)
