"""Every synthetic workpiece family, and one place that draws a rendered case from a seed.

FAMILIES (scenes.py) are the ten the planner was developed in; NEW_FAMILIES add a family per
further joint (issue 22), the curved valley and two scenes holding two kinds (a lap and a
fillet, a V-groove and a square butt). `draw_case(family, seed)` renders exactly as the acceptance tests and golden files always have: the family's narrow default camera and
the default D415 model. `broad=True` draws from the wider world a cell meets: clamps and
loose bars added where they fit (`fixtures.add_clutter`), a camera anywhere in the cone that
sees the seam (`cameras.broad_camera`) and the sensor's ripple, stereo shadow and ragged
incidence limit (`SensorNoise.realistic`). `sensor="hires"` renders through the
high-resolution profile instead of the D415.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from weldseam.synthetic.cameras import broad_camera
from weldseam.synthetic.fixtures import add_clutter
from weldseam.synthetic.joints import (
    bevel, clutter, lap, lap_and_fillet, outside_corner, square_butt, tacked, v_groove_and_square_butt,
)
from weldseam.synthetic.pipes import pipe_on_plate, saddle
from weldseam.synthetic.scenes import (
    FAMILIES, SyntheticScan, SyntheticScene, default_camera, make_scan,
)
from weldseam.synthetic.sensor import D415, HIRES, SensorNoise
from weldseam.synthetic.valley import valley

NEW_FAMILIES: dict[str, Callable[..., SyntheticScene]] = {
    "lap": lap,
    "bevel": bevel,
    "square_butt": square_butt,
    "outside_corner": outside_corner,
    "pipe_on_plate": pipe_on_plate,
    "saddle": saddle,
    "tacked": tacked,
    "clutter": clutter,
    "valley": valley,
    "lap_and_fillet": lap_and_fillet,
    "v_groove_and_square_butt": v_groove_and_square_butt,
}
ALL_FAMILIES: dict[str, Callable[..., SyntheticScene]] = {**FAMILIES, **NEW_FAMILIES}
GROUPS: dict[str, tuple[str, ...]] = {
    "classic": tuple(FAMILIES), "joints": tuple(NEW_FAMILIES), "all": tuple(ALL_FAMILIES),
}
SENSORS = ("d415", "hires")


def draw_case(
    family: str, seed: int, *, broad: bool = False, sensor: str = "d415",
) -> tuple[SyntheticScene, SyntheticScan]:
    """The scene and its rendered scan for (family, seed), all drawn from
    np.random.default_rng(seed) in a fixed order: scene, clutter (broad), camera, sensor.
    Without `broad` and with the D415 this is `make_scan(FAMILIES[family](rng), rng)`,
    byte for byte."""
    if family not in ALL_FAMILIES:
        raise ValueError(f"unknown family {family!r}; known: {', '.join(ALL_FAMILIES)}")
    if sensor not in SENSORS:
        raise ValueError(f"unknown sensor {sensor!r}; known: {', '.join(SENSORS)}")
    rng = np.random.default_rng(seed)
    scene = ALL_FAMILIES[family](rng)
    intrinsics = HIRES if sensor == "hires" else D415
    if broad:
        scene = add_clutter(scene, rng)
        camera = broad_camera(scene, rng, intrinsics)
    else:
        camera = default_camera(scene, rng)
    if sensor == "hires":
        noise = SensorNoise.hires(rng)
    else:
        noise = SensorNoise.realistic(rng) if broad else SensorNoise()
    return scene, make_scan(scene, rng, noise, T_base_camera=camera, intrinsics=intrinsics)
