import numpy as np

from tests.pipeline.test_extend import grid, v_depth
from tests.pipeline.test_section import surface_of
from weldseam.config import TraceConfig
from weldseam.pipeline import section
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.order import Chain
from weldseam.pipeline.probe import probe_chains, tracing_order
from weldseam.pipeline.trace import trace_chain


def test_a_chains_probe_fits_are_reused_by_its_trace_and_give_the_same_seam(rng, monkeypatch):
    """The probes are sections at chain points in the trace's own frames: reusing them saves
    their fits and changes nothing (a wide groove, whose chain along one edge is refitted)."""
    x, y = grid((-0.07, 0.07), (-0.035, 0.035))
    points = np.column_stack([x, y, -v_depth(y, half_open=0.008, depth=0.006)]) + rng.normal(0, 0.0001, (len(x), 3))
    along = np.arange(-0.05, 0.05, 0.0025)
    chain = Chain(np.column_stack([along, np.full(len(along), -0.008), np.zeros(len(along))]), False)
    approx_axes = np.tile([0.0, np.sin(np.radians(15)), -np.cos(np.radians(15))], (len(along), 1))
    surface = surface_of(points)
    probe_fits = probe_chains([chain], [approx_axes], surface)[0]
    assert sorted(probe_fits) == [0, 20, 39] and all(fit.kind == JointKind.V_GROOVE for fit in probe_fits.values())
    fitted = []
    fit_framed = section._fit_framed
    monkeypatch.setattr(section, "_fit_framed", lambda *args: fitted.append(1) or fit_framed(*args))
    reused = trace_chain(chain, approx_axes, probe_fits, surface, TraceConfig())
    fits_with_probes = len(fitted)
    alone = trace_chain(chain, approx_axes, {}, surface, TraceConfig())
    assert fits_with_probes == len(fitted) - fits_with_probes - 2 * len(probe_fits), "each probe fitted twice, once"
    assert len(reused) == len(alone) == 1
    assert np.array_equal(reused[0].positions_m, alone[0].positions_m)
    assert np.array_equal(reused[0].torch_axes, alone[0].torch_axes)
    assert np.abs(reused[0].positions_m[:, 1:]).max() < 0.0005, "on the seam line, at the surface"


def test_a_chain_on_the_seam_is_traced_before_a_longer_one_along_its_edge(rng):
    """A groove along x: a chain along its edge (8 mm off, longer) and one on its seam line; both
    probes fit the groove, the one on the seam finds it under its own points."""
    x, y = grid((-0.07, 0.07), (-0.035, 0.035))
    surface = surface_of(np.column_stack([x, y, -v_depth(y, half_open=0.008, depth=0.006)]))
    down = [0.0, 0.0, -1.0]
    on_seam = Chain(np.column_stack([np.arange(-0.04, 0.04, 0.0025), np.zeros(32), np.zeros(32)]), False)
    along_edge = Chain(np.column_stack([np.arange(-0.06, 0.06, 0.0025), np.full(48, 0.008), np.zeros(48)]), False)
    chains = [along_edge, on_seam]
    probes = probe_chains(chains, [np.tile(down, (len(c.points), 1)) for c in chains], surface)
    assert all(fit.kind == JointKind.V_GROOVE for p in probes for fit in p.values())
    order = sorted(range(2), key=lambda k: tracing_order(chains[k], probes[k]))
    assert order == [1, 0]


def test_a_chain_shorter_than_the_trace_takes_is_not_probed_and_the_others_probe_as_alone():
    """A chain shorter than min_length_m (the trace rejects it as SHORT_CHAIN) gets no probe
    sections; the chains beside it get the probes they get alone."""
    x, y = grid((-0.07, 0.07), (-0.035, 0.035))
    surface = surface_of(np.column_stack([x, y, -v_depth(y, half_open=0.008, depth=0.006)]))
    down = [0.0, 0.0, -1.0]
    on_seam = Chain(np.column_stack([np.arange(-0.04, 0.04, 0.0025), np.zeros(32), np.zeros(32)]), False)
    speck = Chain(np.array([[0.01, 0.0, 0.0], [0.0105, 0.0, 0.0]]), False)  # 0.5 mm long
    chains = [speck, on_seam]
    axes = [np.tile(down, (len(c.points), 1)) for c in chains]
    probes = probe_chains(chains, axes, surface, min_length_m=0.002)
    alone = probe_chains([on_seam], axes[1:], surface, min_length_m=0.002)[0]
    assert probes[0] == {}
    assert sorted(probes[1]) == sorted(alone) == [0, 16, 31]
    assert all(np.array_equal(probes[1][k].point_m, alone[k].point_m) for k in alone)
    assert all(fit.kind == JointKind.V_GROOVE for fit in alone.values())
    assert probe_chains([speck], axes[:1], surface, min_length_m=0.002) == [{}]


def test_a_short_chain_is_probed_once_per_stretch_the_trace_bridges():
    """Probes closer than the trace's max_gap_m are one place to it: a chain shorter than that
    gets one probe in its middle, one up to twice as long two (its ends), longer ones three."""
    x, y = grid((-0.07, 0.07), (-0.035, 0.035))
    surface = surface_of(np.column_stack([x, y, -v_depth(y, half_open=0.008, depth=0.006)]))
    stretch = TraceConfig().max_gap_m
    chains = [Chain(np.column_stack([np.arange(n) * 0.0025, np.zeros(n), np.zeros(n)]), False)
              for n in (3, 7, 16)]  # 5, 15 and 37.5 mm
    axes = [np.tile([0.0, 0.0, -1.0], (len(c.points), 1)) for c in chains]
    probes = probe_chains(chains, axes, surface, min_length_m=0.002, stretch_m=stretch)
    assert [sorted(p) for p in probes] == [[1], [0, 6], [0, 8, 15]]
    assert all(fit.kind == JointKind.V_GROOVE for p in probes for fit in p.values())
    assert [sorted(p) for p in probe_chains(chains, axes, surface, min_length_m=0.002)] == [[0, 1, 2], [0, 3, 6],
                                                                                             [0, 8, 15]]
