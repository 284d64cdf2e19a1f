"""What stands around a workpiece and is never a seam: supports under a tilted part, clamps on
plate edges, loose bars on the table.

Supports are built under a workpiece before it is placed (`rest_on_support`). Clamps and bars
are added to a finished scene (`add_clutter`): each candidate is checked against a height map
of the scene (rays cast straight down every `GRID_STEP_M`), so a clamp's arm lies exactly on a
flat top and its post and every bar stand on bare table: by construction nothing overlaps
the part or another fixture. Units: metres, base frame z up, table top at z = 0.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np
import trimesh

from weldseam.geometry import transform_points, unit
from weldseam.synthetic.scenes import (
    UP, SyntheticScene, TruthSeam, _convex_solid, _draw, _moved, _rotation,
)
from weldseam.synthetic.sensor import cast_rays

GRID_STEP_M = 0.001
GRID_HALF_SIZE_M = 0.3
FLAT_TOLERANCE_M = 1e-5
SEAM_CLEARANCE_M = 0.015


class Supported(NamedTuple):
    """A workpiece resting on a support: its moved parts and seams, the support solids and
    the rigid (4, 4) move that took it from flat on the table to where it rests."""

    parts: list
    seams: list
    supports: list
    move: np.ndarray


def rest_on_support(
    parts, seams, rng: np.random.Generator, kind: str, *, incline_deg=None, axis_deg=None,
    height_m=None,
) -> Supported:
    """Tilt a workpiece lying flat on z = 0 by `incline_deg` (15-35) about a horizontal axis
    at `axis_deg` (0-180) from x, lift it until its lowest point is `height_m` (10-30 mm)
    above the table, and build `kind` under its bottom face: "wedge" (one solid from the
    bottom face straight down to the table) or "blocks" (two such solids under the two ends
    of the bottom face, 25-35 % of its extent each, along the slope). Supports touch the
    bottom face and the table and nothing else."""
    if kind not in ("wedge", "blocks"):
        raise ValueError(f"rest_on_support: kind must be 'wedge' or 'blocks', got {kind!r}")
    axis_angle = np.radians(_draw(rng, axis_deg, 0.0, 180.0))
    axis = np.array([np.cos(axis_angle), np.sin(axis_angle), 0.0])
    tilt = _rotation(axis, np.radians(_draw(rng, incline_deg, 15.0, 35.0)))
    vertices = np.vstack([np.asarray(p.vertices) for p in parts])
    lift = np.eye(4)
    lift[2, 3] = _draw(rng, height_m, 0.01, 0.03) - transform_points(tilt, vertices)[:, 2].min()
    move = lift @ tilt
    parts, seams = _moved(move, parts, seams)

    from scipy.spatial import ConvexHull

    bottom = transform_points(move, vertices[np.abs(vertices[:, 2]) < 1e-9])
    shadow = ConvexHull(bottom[:, :2])
    down = move[:3, :3] @ -UP  # the bottom face's outward normal
    normals = [np.r_[eq[:2], 0.0] for eq in shadow.equations] + [-down, -UP]
    offsets = [-eq[2] for eq in shadow.equations] + [-down @ bottom[0], 0.0]
    if kind == "wedge":
        return Supported(parts, seams, [_convex_solid(np.array(normals), np.array(offsets))], move)
    slope = unit(np.r_[down[:2], 0.0])  # horizontal, along the slope
    along = bottom @ slope
    low, high = along.min(), along.max()
    blocks = []
    for start, end in ((low, low + rng.uniform(0.25, 0.35) * (high - low)),
                       (high - rng.uniform(0.25, 0.35) * (high - low), high)):
        band_normals = normals + [slope, -slope]
        band_offsets = offsets + [end, -start]
        blocks.append(_convex_solid(np.array(band_normals), np.array(band_offsets)))
    return Supported(parts, seams, blocks, move)


# ---------------------------------------------------------------- clutter on a finished scene


class _HeightMap(NamedTuple):
    """Heights (n, n) of the highest surface over a square grid (-inf where nothing is hit)
    and the cells (n, n) clutter already occupies. Cell (i, j) is at centre + (grid[j],
    grid[i])."""

    centre_xy: np.ndarray
    grid: np.ndarray
    heights: np.ndarray
    occupied: np.ndarray

    def cells(self, origin_xy, heading, along, across):
        """(n, n) bool: cells inside the rectangle along in [along], across in [across]
        (pairs, m) of a frame at `origin_xy` turned by `heading` (rad)."""
        x = self.centre_xy[0] + self.grid[None, :] - origin_xy[0]
        y = self.centre_xy[1] + self.grid[:, None] - origin_xy[1]
        u = x * np.cos(heading) + y * np.sin(heading)
        v = -x * np.sin(heading) + y * np.cos(heading)
        return (u >= along[0]) & (u <= along[1]) & (v >= across[0]) & (v <= across[1])


def _height_map(mesh, centre_xy) -> _HeightMap:
    """Height map of `mesh` around `centre_xy` (2,), GRID_HALF_SIZE_M each way."""
    grid = np.arange(-GRID_HALF_SIZE_M, GRID_HALF_SIZE_M + GRID_STEP_M / 2, GRID_STEP_M)
    xs, ys = np.meshgrid(centre_xy[0] + grid, centre_xy[1] + grid)
    origins = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, 2.0)])
    t_hit, _ = cast_rays(mesh, origins, np.broadcast_to(-UP, origins.shape))
    heights = np.where(np.isfinite(t_hit), 2.0 - t_hit, -np.inf).reshape(xs.shape)
    return _HeightMap(np.asarray(centre_xy, float), grid, heights, np.zeros(heights.shape, bool))


def _box_at(origin_xy, heading, along, across, bottom_m, top_m) -> trimesh.Trimesh:
    """Box over the rectangle of `_HeightMap.cells` from height bottom_m to top_m."""
    box = trimesh.creation.box(bounds=[[along[0], across[0], bottom_m], [along[1], across[1], top_m]])
    box.apply_transform(_rotation(UP, heading))
    return box.apply_translation([origin_xy[0], origin_xy[1], 0.0])


def _clear_of_seams(seams, origin_xy, heading, along, across, top_m) -> bool:
    """True when every truth point is SEAM_CLEARANCE_M or more from the box over the
    rectangle up to `top_m`."""
    points = np.vstack([s.points_m for s in seams]) if seams else np.empty((0, 3))
    relative = points[:, :2] - origin_xy
    u = relative @ [np.cos(heading), np.sin(heading)]
    v = relative @ [-np.sin(heading), np.cos(heading)]
    gaps = np.column_stack([
        np.maximum(0.0, np.maximum(along[0] - u, u - along[1])),
        np.maximum(0.0, np.maximum(across[0] - v, v - across[1])),
        np.maximum(0.0, points[:, 2] - top_m),
    ])
    return bool(np.all(np.linalg.norm(gaps, axis=1) >= SEAM_CLEARANCE_M))


def _clamp(heights: _HeightMap, seams, target_xy, rng):
    """One hold-down clamp on a plate edge, or None where this draw finds no site: an arm
    (20-30 mm wide, 6-10 mm thick) lying on a flat top 12-25 mm in from the part's outer edge
    along a random heading, reaching out over a 3-8 mm gap to a post that stands on the
    table (15-25 mm long). Returns (meshes, occupied cells, top height)."""
    heading = rng.uniform(0.0, 2 * np.pi)
    reach, gap, post = rng.uniform([0.012, 0.003, 0.015], [0.025, 0.008, 0.025])
    width, thickness = rng.uniform([0.020, 0.006], [0.030, 0.010])
    # The part's outermost edge along the heading: the last grid cell above 1 mm.
    radii = np.arange(0.0, GRID_HALF_SIZE_M - 0.05, GRID_STEP_M / 2)
    probe = target_xy + radii[:, None] * [np.cos(heading), np.sin(heading)]
    index = np.clip(np.rint((probe - heights.centre_xy + GRID_HALF_SIZE_M) / GRID_STEP_M).astype(int),
                    0, len(heights.grid) - 1)
    above = np.nonzero(heights.heights[index[:, 1], index[:, 0]] > 0.001)[0]
    if len(above) == 0:
        return None
    edge = radii[above.max()]
    row, col = index[max(above.max() - 6, 0)][::-1]  # 3 mm inside the edge
    top = heights.heights[row, col]
    across = (-width / 2, width / 2)
    arm = (edge - reach, edge + gap + post)
    margin = 1.5 * GRID_STEP_M
    arm_cells = heights.cells(target_xy, heading, (arm[0] - margin, arm[1] + margin),
                              (across[0] - margin, across[1] + margin))
    post_cells = heights.cells(target_xy, heading, (edge + gap - margin, arm[1] + margin),
                               (across[0] - margin, across[1] + margin))
    on_top = arm_cells & (np.abs(heights.heights - top) <= FLAT_TOLERANCE_M)
    on_table = np.abs(heights.heights) <= FLAT_TOLERANCE_M
    arm_rests = np.all((on_top | on_table)[arm_cells]) and on_top.sum() >= 0.3 * arm_cells.sum()
    post_stands = np.all(on_table[post_cells])
    if not (top > 0.002 and arm_rests and post_stands and not heights.occupied[arm_cells].any()
            and _clear_of_seams(seams, target_xy, heading, arm, across, top + thickness)):
        return None
    meshes = [
        _box_at(target_xy, heading, arm, across, top, top + thickness),
        _box_at(target_xy, heading, (edge + gap, arm[1]), across, 0.0, top),
    ]
    return meshes, arm_cells, top + thickness


def _loose_bar(heights: _HeightMap, target_xy, rng):
    """One bar lying on bare table 50-200 mm from the target, or None where this draw finds
    no room: round (radius 5-12 mm, 32 facets) or square (10-25 mm), 60-150 mm long, any
    heading. Returns (meshes, occupied cells, top height)."""
    heading, bearing = rng.uniform(0.0, 2 * np.pi, 2)
    distance, length = rng.uniform([0.05, 0.06], [0.20, 0.15])
    round_bar = bool(rng.integers(2))
    size = rng.uniform(0.010, 0.024) if round_bar else rng.uniform(0.010, 0.025)
    centre = target_xy + distance * np.array([np.cos(bearing), np.sin(bearing)])
    along, across = (-length / 2, length / 2), (-size / 2, size / 2)
    margin = 1.5 * GRID_STEP_M
    cells = heights.cells(centre, heading, (along[0] - margin, along[1] + margin),
                          (across[0] - margin, across[1] + margin))
    if not np.all(np.abs(heights.heights[cells]) <= FLAT_TOLERANCE_M) or heights.occupied[cells].any():
        return None
    if round_bar:
        bar = trimesh.creation.cylinder(radius=size / 2, height=length, sections=32)
        bar.apply_transform(_rotation([0.0, 1.0, 0.0], np.pi / 2))  # lying along x
        bar.apply_translation([0.0, 0.0, -bar.vertices[:, 2].min()])  # lowest edge on the table
        bar.apply_transform(_rotation(UP, heading))
        bar.apply_translation([centre[0], centre[1], 0.0])
    else:
        bar = _box_at(centre, heading, along, across, 0.0, size)
    return [bar], cells, size


def add_clutter(
    scene: SyntheticScene, rng: np.random.Generator, *, clamps: int | None = None,
    bars: int | None = None, attempts: int = 40,
) -> SyntheticScene:
    """The scene with up to `clamps` clamps on its parts' edges and `bars` loose bars on the
    table (0-2 of each when None), as fixtures. Each is sought over `attempts` random draws;
    a scene with no flat top near an edge (a pipe) gets no clamp."""
    clamps = int(rng.integers(0, 3)) if clamps is None else clamps
    bars = int(rng.integers(0, 3)) if bars is None else bars
    target_xy = np.asarray(scene.camera_target_m, float)[:2]
    heights = _height_map(scene.mesh, target_xy)
    added = []
    for build, wanted in ((_clamp_builder(scene.seams), clamps), (_loose_bar, bars)):
        for _ in range(wanted):
            for _ in range(attempts):
                found = build(heights, target_xy, rng)
                if found is not None:
                    meshes, cells, top = found
                    added += meshes
                    heights.heights[cells] = top
                    heights.occupied[cells] = True
                    break
    if not added:
        return scene
    return dataclasses.replace(
        scene,
        mesh=trimesh.util.concatenate([scene.mesh, *added]),
        fixtures=scene.fixtures + tuple(added),
        occluder=None if scene.occluder is None else trimesh.util.concatenate([scene.occluder, *added]),
    )


def _clamp_builder(seams: tuple[TruthSeam, ...]):
    """`_clamp` with the scene's seams bound, shaped like `_loose_bar`."""
    return lambda heights, target_xy, rng: _clamp(heights, seams, target_xy, rng)
