from contextlib import ExitStack

import numpy as np

from weldseam.config import PlanConfig
from weldseam.pipeline.neighbours import centroid_offsets
from weldseam.pipeline.state import PlanState
from weldseam.types import Scan


def plate(height_m: float) -> np.ndarray:
    """A 40 mm square at 2.5 mm pitch, its half x > 0 raised by `height_m` per metre of x."""
    ticks = np.arange(-0.02, 0.0201, 0.0025)
    u, v = (a.ravel() for a in np.meshgrid(ticks, ticks, indexing="ij"))
    return np.column_stack([u, v, np.where(u > 0, u * height_m, 0.0)])


def test_the_centroid_offsets_are_computed_once_and_follow_a_new_working_cloud():
    flat = plate(0.0)
    state = PlanState(Scan(points_m=flat), PlanConfig(), ExitStack(), lambda *_: None)
    state.working = flat
    before = state.centroid_offsets(0.006)
    assert state.centroid_offsets(0.006) is before
    assert np.abs(before[:, 2]).max() < 1e-12  # a plane: no offset along its normal
    state.working = plate(1.0)  # a 45-degree fold: its points now have neighbours above them
    after = state.centroid_offsets(0.006)
    assert np.array_equal(after, centroid_offsets(state.neighbourhoods(0.006), state.working))
    fold = (np.abs(state.working[:, 0]) < 0.001) & (np.abs(state.working[:, 1]) < 0.01)
    assert after[fold, 2].min() > 0.0005
