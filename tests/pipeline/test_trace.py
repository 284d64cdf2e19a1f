import numpy as np

from weldseam.config import TraceConfig
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.order import Chain
from weldseam.pipeline.section import SectionFit
from weldseam.pipeline.trace import TracedSeam, inside_traced, trace_chain

STEP_M = 0.002


def test_a_line_along_a_traced_grooves_edge_is_inside_it_and_a_line_beside_it_is_not():
    along = np.arange(0.0, 0.1, STEP_M)
    seam = TracedSeam(
        np.column_stack([along, np.zeros_like(along), np.zeros_like(along)]), np.tile([0.0, 0.0, -1.0], (50, 1)),
        False, JointKind.V_GROOVE, 1.0, half_opening_m=0.004,
    )
    edge_line = np.column_stack([along[5:40:3], np.full(12, 0.0085), np.zeros(12)])  # 4 + 4.5 mm aside
    assert inside_traced(edge_line, [seam], beside_m=0.006)
    assert not inside_traced(edge_line + [0.0, 0.002, 0.0], [seam], beside_m=0.006), "a parallel line 10.5 mm off"
    beyond = np.column_stack([np.arange(0.112, 0.122, 0.002), np.full(5, 0.0085), np.zeros(5)])
    past_the_end = np.vstack([edge_line, beyond])  # 30 % of it past the seam's end
    assert not inside_traced(past_the_end, [seam], beside_m=0.006), "a line going on past the seam's end"
    assert not inside_traced(edge_line, [], beside_m=0.006)




def test_a_line_mostly_inside_a_traced_seam_is_inside_it():
    along = np.arange(0.0, 0.1, STEP_M)
    seam = TracedSeam(np.column_stack([along, np.zeros(50), np.zeros(50)]), np.tile([0.0, 0.0, -1.0], (50, 1)),
                      False, JointKind.V_GROOVE, 1.0, half_opening_m=0.004)
    longer = np.column_stack([np.arange(0.0, 0.115, STEP_M), np.full(58, 0.005), np.zeros(58)])  # 86 % beside it
    assert inside_traced(longer, [seam], beside_m=0.006)
    half_outside = np.column_stack([np.arange(0.05, 0.15, STEP_M), np.full(50, 0.005), np.zeros(50)])
    assert not inside_traced(half_outside, [seam], beside_m=0.006)


class ModelsSurface:
    """A stand-in FineSurface whose sections along y = 0 fit a V-groove at the section centre,
    except every third, which another model (a lap 3 mm aside) explains better unless only the
    V-groove is sought."""

    def fit_many(self, centres, travel, axes, lateral, kinds=None):
        fits = []
        for centre in centres:
            other = round(centre[0] / STEP_M) % 3 == 0 and (kinds is None or JointKind.LAP in kinds)
            kind, point = (JointKind.LAP, centre + [0.0, 0.003, 0.0]) if other else (JointKind.V_GROOVE, centre)
            fits.append(SectionFit(kind, point, np.array([0.0, 0.0, -1.0])))
        return fits


def test_sections_another_model_explains_better_are_fitted_again_as_the_chains_joint():
    along = np.arange(0.0, 0.1, STEP_M)
    chain = Chain(np.column_stack([along, np.zeros_like(along), np.zeros_like(along)]), False)
    axes = np.tile([0.0, 0.0, -1.0], (len(along), 1))
    (seam,) = trace_chain(chain, axes, {}, ModelsSurface(), TraceConfig())
    assert seam.joint == JointKind.V_GROOVE
    assert len(seam.positions_m) == len(along) and np.abs(seam.positions_m[:, 1]).max() < 1e-12
