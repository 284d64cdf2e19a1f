"""The range of every number `check` and `send` accept: one table, refused before anything connects.

The option checks, the --help texts and the README's options table all read LIMITS, so the
three cannot drift apart. A value outside its range (or NaN) raises InputError naming the option.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from weldseam.errors import InputError

STANDARD_DIGITAL_OUTPUTS = range(8)
# Universal Robots' rated payloads (kg); the torch, its cable package and any sensor must stay under them.
RATED_PAYLOAD_KG = {"ur5": 5.0, "ur5e": 5.0, "ur10": 10.0}


@dataclass(frozen=True)
class Limit:
    """low <= value <= high (low < value when low_open); unit as the option spells it; why the range is what it is."""

    option: str
    low: float
    high: float
    unit: str
    why: str
    low_open: bool = False

    def text(self) -> str:
        """The range as a user reads it: "0 to 50 mm", "over 0 up to 100 mm/s"."""
        low = f"over {self.low:g} up" if self.low_open else f"{self.low:g}"
        return f"{low} to {self.high:g} {self.unit}".rstrip()

    def check(self, value: float) -> float:
        inside = self.low < value if self.low_open else self.low <= value
        if not (math.isfinite(value) and inside and value <= self.high):
            raise InputError(f"{self.option} {value:g}: must be {self.text()} ({self.why})")
        return value


LIMITS: dict[str, Limit] = {
    limit.option: limit
    for limit in (
        Limit("--standoff-mm", 0.0, 50.0, "mm", "a negative stick-out puts the torch tip inside the work"),
        Limit("--work-angle-deg", -45.0, 45.0, "deg", "tilt about the travel direction, from the joint's bisector"),
        Limit("--travel-angle-deg", -30.0, 30.0, "deg", "push/drag lean; above ~20 deg the arc is unstable"),
        Limit("--tolerance-mm", 0.0, 0.5, "mm", "decimation error adds to the path's 0.5 mm budget", low_open=True),
        Limit("--angle-tolerance-deg", 0.0, 10.0, "deg", "decimation error in torch orientation", low_open=True),
        Limit("--approach-mm", 5.0, 300.0, "mm", "the torch reaches the weld start along its own axis"),
        Limit("--blend-mm", 0.0, 10.0, "mm", "a blend cuts the corner it rounds"),
        Limit("--speed-mm-s", 0.0, 100.0, "mm/s", "arc welding travels 2-25 mm/s, laser up to ~100", low_open=True),
        Limit("--move-speed-mm-s", 0.0, 250.0, "mm/s", "ISO 10218-1's reduced speed, near the fixture", low_open=True),
        Limit("--payload-kg", 0.0, max(RATED_PAYLOAD_KG.values()), "kg",
              "and at most the arm's rated payload: UR5/UR5e 5 kg, UR10 10 kg", low_open=True),  # fmt: skip
        Limit("--payload-cog-m", 0.0, 0.5, "m", "distance of the centre of gravity from the flange"),
        Limit("--tcp", 0.0, 0.6, "m", "distance of the torch tip from the flange"),
        Limit("--arc-do", STANDARD_DIGITAL_OUTPUTS[0], STANDARD_DIGITAL_OUTPUTS[-1], "",
              "the standard digital outputs of the control box"),  # fmt: skip
    )
}


def checked(option: str, value: float) -> float:
    """value, if it is inside the range of `option` (InputError otherwise)."""
    return LIMITS[option].check(value)


def checked_payload(mass_kg: float, robot: str) -> float:
    """The payload mass, inside its range and at most the rated payload of `robot`."""
    checked("--payload-kg", mass_kg)
    rated_kg = RATED_PAYLOAD_KG[robot]
    if mass_kg > rated_kg:
        raise InputError(f"--payload-kg {mass_kg:g}: over the {robot}'s rated payload of {rated_kg:g} kg")
    return mass_kg
