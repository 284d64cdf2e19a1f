"""Ordering: turn unordered seam points into chains (open, closed, split at branches)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import minimum_spanning_tree
from scipy.spatial import cKDTree

from weldseam.geometry import polyline_length


@dataclass(frozen=True)
class Chain:
    """Ordered seam points (K, 3); `closed` when the last point joins the first."""

    points: np.ndarray
    closed: bool


def order_chains(points: np.ndarray, *, link_m: float, min_branch_m: float) -> list[Chain]:
    """Order (N, 3) seam points into chains.

    The points are linked to neighbours within `link_m` and reduced to their minimum
    spanning tree, which has no cycles, so walking it always ends (the reference code's
    nearest-neighbour walk never ended on a ring). Side branches shorter than
    `min_branch_m` are noise and pruned; the remaining tree is cut at its junctions
    (T and Y seams) into separate chains. A chain whose two ends are within `link_m` of
    each other is a closed loop. Every point of a kept branch is in exactly one chain.
    """
    if len(points) < 2:
        return []
    adjacency = _spanning_tree(points, link_m)
    _prune_spurs(adjacency, points, min_branch_m)
    chains = []
    for nodes in _branches(adjacency):
        chain_points = points[nodes]
        closed = (
            len(nodes) >= 4
            and np.linalg.norm(chain_points[0] - chain_points[-1]) <= link_m
            and polyline_length(chain_points) > 4 * link_m
        )
        if not closed and _key(chain_points[-1]) < _key(chain_points[0]):
            chain_points = chain_points[::-1]
        chains.append(Chain(points=chain_points, closed=bool(closed)))
    return chains


def _spanning_tree(points: np.ndarray, link_m: float) -> dict[int, set[int]]:
    tree = cKDTree(points)
    distances = tree.sparse_distance_matrix(tree, link_m, output_type="coo_matrix")
    # Coincident points would have weight 0, which the MST routine reads as "no edge".
    weights = sparse.coo_matrix((distances.data + 1e-12, (distances.row, distances.col)), shape=distances.shape)
    spanning = minimum_spanning_tree(weights.tocsr()).tocoo()
    adjacency: dict[int, set[int]] = {i: set() for i in range(len(points))}
    for a, b in zip(spanning.row.tolist(), spanning.col.tolist()):
        adjacency[a].add(b)
        adjacency[b].add(a)
    return adjacency


def _prune_spurs(adjacency: dict[int, set[int]], points: np.ndarray, min_branch_m: float) -> None:
    """Remove leaf-to-junction runs shorter than min_branch_m, until none is left. A run is
    walked from its leaf only until it reaches min_branch_m (a seam's own chain is hundreds of
    points long, and each of its two leaves is tried on every round)."""
    coordinates = points.tolist()
    changed = True
    while changed:
        changed = False
        for leaf in [node for node, near in adjacency.items() if len(near) == 1]:
            if leaf not in adjacency or len(adjacency[leaf]) != 1:
                continue
            run, length = [leaf], 0.0
            previous, current = leaf, next(iter(adjacency[leaf]))
            while len(adjacency[current]) == 2 and length < min_branch_m:
                length += math.dist(coordinates[current], coordinates[previous])
                run.append(current)
                previous, current = current, next(n for n in adjacency[current] if n != previous)
            length += math.dist(coordinates[current], coordinates[previous])
            if len(adjacency[current]) >= 3 and length < min_branch_m:
                for node in run:
                    for near in adjacency.pop(node):
                        if near in adjacency:
                            adjacency[near].discard(node)
                changed = True
    for node in [node for node, near in adjacency.items() if not near]:
        del adjacency[node]


def _branches(adjacency: dict[int, set[int]]) -> list[list[int]]:
    """Split the forest into runs between nodes of degree != 2 (leaves and junctions)."""
    ends = sorted(node for node, near in adjacency.items() if len(near) != 2)
    visited_edges: set[tuple[int, int]] = set()
    branches = []
    for start in ends:
        for first in sorted(adjacency[start]):
            if (start, first) in visited_edges:
                continue
            run = [start, first]
            visited_edges.update({(start, first), (first, start)})
            while len(adjacency[run[-1]]) == 2:
                following = next(n for n in adjacency[run[-1]] if n != run[-2])
                visited_edges.update({(run[-1], following), (following, run[-1])})
                run.append(following)
            branches.append(run)
    return branches


def _key(point: np.ndarray) -> tuple[float, float, float]:
    """Deterministic start-end choice: the end with the smaller (x, y, z), to 0.1 mm."""
    return tuple(np.round(point / 1e-4).tolist())
