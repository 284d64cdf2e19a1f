"""Geometric helpers shared by the synthetic-scene tests."""

import numpy as np

from weldseam.geometry import unit
from weldseam.synthetic.sensor import cast_rays


def distance_to_mesh(mesh, points):
    """(N,) unsigned distance (m) from points (N, 3) to a triangle mesh (Open3D, float32)."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, np.float32)),
                        o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)))
    return scene.compute_distance(o3d.core.Tensor(np.asarray(points, np.float32))).numpy()


def signed_distance(mesh, points):
    """(N,) signed distance (m, negative inside) from points (N, 3) to a closed mesh."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, np.float32)),
                        o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)))
    return scene.compute_signed_distance(o3d.core.Tensor(np.asarray(points, np.float32))).numpy()


def opening_edges(mesh, point, axis, across, *, step_m=1e-5, inner_m=0.012, outer_m=0.022,
                  deviation_m=2e-5):
    """The two top edges of a groove around `point`, found from the mesh alone.

    Rays along the torch `axis` start 20 mm behind `point` every `step_m` across the seam
    (direction `across`). On each side a line fitted to the hits between inner_m and outer_m
    from the seam is that side's outer surface; the edge is where, coming in from outside,
    the hits first fall deeper than that line by `deviation_m`. Returns the two edge points
    (3,) and the two surface lines' slopes (depth per metre across)."""
    offsets = np.arange(-outer_m, outer_m + step_m / 2, step_m)
    origins = point - 0.02 * axis + offsets[:, None] * across
    t_hit, _ = cast_rays(mesh, origins, np.broadcast_to(axis, origins.shape))
    edges, slopes = [], []
    for side in (-1.0, 1.0):
        outside = (side * offsets >= inner_m) & (side * offsets <= outer_m)
        slope, intercept = np.polyfit(offsets[outside], t_hit[outside], 1)
        deeper = (t_hit - (intercept + slope * offsets)) > deviation_m
        inward = np.nonzero((side * offsets < inner_m) & (side * offsets >= 0))[0]
        inward = inward[np.argsort(-side * offsets[inward])]  # from outside toward the seam
        first = inward[np.argmax(deeper[inward])]
        edge = offsets[first] + side * step_m / 2
        edges.append(point - 0.02 * axis + edge * across + (intercept + slope * edge) * axis)
        slopes.append(slope)
    return edges, slopes


def seam_frame(seam, index):
    """Unit tangent and across direction (3,) of a truth seam at point `index`."""
    points = seam.points_m
    tangent = unit(points[min(index + 1, len(points) - 1)] - points[max(index - 1, 0)])
    return tangent, unit(np.cross(tangent, seam.torch_axes[index]))


def polyline_projection(points, query):
    """Distance (m) from `query` (3,) to the polyline `points` (M, 3), and the arc length
    (m) along it of the nearest point."""
    starts, ends = points[:-1], points[1:]
    steps = ends - starts
    fraction = np.clip(np.sum((query - starts) * steps, axis=1) / np.sum(steps**2, axis=1), 0, 1)
    nearest = starts + fraction[:, None] * steps
    distance = np.linalg.norm(nearest - query, axis=1)
    best = int(np.argmin(distance))
    along = np.r_[0.0, np.cumsum(np.linalg.norm(steps, axis=1))]
    return distance[best], along[best] + fraction[best] * np.linalg.norm(steps[best])
