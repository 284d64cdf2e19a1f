import numpy as np

from weldseam.pipeline.order import order_chains


def test_a_ring_is_one_closed_chain_and_ordering_terminates():
    angles = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    ring = np.column_stack([0.05 * np.cos(angles), 0.05 * np.sin(angles), np.zeros(120)])
    chains = order_chains(ring[np.random.default_rng(0).permutation(120)], link_m=0.008, min_branch_m=0.015)
    assert len(chains) == 1 and chains[0].closed
    assert len(chains[0].points) == 120
    steps = np.linalg.norm(np.diff(chains[0].points, axis=0), axis=1)
    assert steps.max() < 0.004  # neighbours in order, no jumps across the ring


def test_a_y_junction_splits_into_three_branches_with_no_point_lost():
    t = np.arange(0.003, 0.06, 0.003)
    arms = [np.column_stack([t * np.cos(a), t * np.sin(a), np.zeros_like(t)]) for a in (0, 2.1, 4.2)]
    points = np.vstack([[[0.0, 0.0, 0.0]], *arms])
    chains = order_chains(points, link_m=0.005, min_branch_m=0.015)
    assert len(chains) == 3
    assert not any(c.closed for c in chains)
    used = np.vstack([c.points for c in chains])
    assert len(np.unique(used.round(9), axis=0)) == len(points)


def test_a_short_spur_is_pruned_and_the_line_is_ordered_end_to_end():
    line = np.column_stack([np.arange(0, 0.1, 0.003), np.zeros(34), np.zeros(34)])
    spur = np.array([[0.051, 0.003, 0.0], [0.051, 0.006, 0.0]])
    chains = order_chains(np.vstack([line[::-1], spur]), link_m=0.005, min_branch_m=0.015)
    assert len(chains) == 1 and not chains[0].closed
    assert np.all(np.diff(chains[0].points[:, 0]) > 0)  # monotonic: ordered, starts at the smaller x
    assert len(chains[0].points) == 34


def test_two_separate_lines_give_two_chains():
    line = np.column_stack([np.arange(0, 0.05, 0.003), np.zeros(17), np.zeros(17)])
    chains = order_chains(np.vstack([line, line + [0, 0.05, 0]]), link_m=0.005, min_branch_m=0.015)
    assert len(chains) == 2


def test_a_spur_longer_than_min_branch_is_a_branch_and_a_shorter_one_is_pruned():
    """The walk from a spur's leaf stops once min_branch_m is reached: the decision at the
    junction must not change (a spur of 18 mm stays, 12 mm goes, with min_branch_m 15 mm)."""
    line = np.column_stack([np.arange(0, 0.1, 0.003), np.zeros(34), np.zeros(34)])
    for points_on_spur, chains_expected in ((6, 3), (4, 1)):
        spur = np.column_stack([np.full(points_on_spur, 0.051), 0.003 * np.arange(1, points_on_spur + 1),
                                np.zeros(points_on_spur)])  # fmt: skip
        chains = order_chains(np.vstack([line, spur]), link_m=0.0035, min_branch_m=0.015)
        assert len(chains) == chains_expected
        used = np.unique(np.vstack([chain.points for chain in chains]).round(9), axis=0)
        assert len(used) == 34 + (points_on_spur if chains_expected == 3 else 0), "no point lost but the pruned"
