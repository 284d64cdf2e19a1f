"""When a fit ahead of a seam's end counts as the seam (seek.next_fit)."""

import numpy as np

from weldseam.config import ExtendConfig
from weldseam.pipeline import seek
from weldseam.pipeline.ends import offsets
from weldseam.pipeline.joints import JointGeometry, JointKind
from weldseam.pipeline.section import SectionFit
from weldseam.pipeline.seek import Extension, next_fit

AXIS = np.array([0.0, 0.0, -1.0])
HEADING = (np.array([1.0, 0.0, 0.0]), np.zeros(3))


def _fit_sideways(monkeypatch, sideways_m: float, included_deg: float) -> None:
    """Every section ahead finds a fillet `sideways_m` across from where it was sought, its faces
    `included_deg` apart."""

    def section_at(extension, predicted, travel, axis, template=None):
        point = predicted + np.array([0.0, sideways_m, 0.0])
        fit = SectionFit(JointKind.FILLET, point, AXIS, JointGeometry(included_deg=included_deg))
        return fit, *offsets(point, predicted, travel, axis)

    monkeypatch.setattr(seek, "section_at", section_at)


def test_a_flat_fit_does_not_widen_its_own_reach_past_the_seams(monkeypatch):
    params = ExtendConfig()
    extension = Extension(surface=None, joint=JointKind.FILLET, params=params)
    start = np.zeros(3)
    # A 160-degree "corner" (ripple on a tube beside a valley) 10 mm across: its own across_spread
    # (5.7) would take it, a seam of 90-degree corners (spread 1) does not.
    _fit_sideways(monkeypatch, 0.010, 160.0)
    assert next_fit(extension, start, AXIS, HEADING) is not None
    assert next_fit(extension, start, AXIS, HEADING, end_spread=1.0) is None
    # The seam's own shallow valley (150 degrees, spread 3.7) keeps its wide reach.
    assert next_fit(extension, start, AXIS, HEADING, end_spread=3.7) is not None
    # A fit on the seam's line is taken either way.
    _fit_sideways(monkeypatch, 0.001, 160.0)
    assert next_fit(extension, start, AXIS, HEADING, end_spread=1.0) is not None
