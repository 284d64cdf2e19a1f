import numpy as np
import pytest

from tests.test_pipeline_helpers import crease_points
from weldseam.errors import InputError
from weldseam.pipeline.descriptor import descriptor_and_offsets, gradient_descriptor, valley_depth
from weldseam.pipeline.neighbours import centroid_offsets, radius_graph
from weldseam.pipeline.normals import estimate_normals, pca_normals


@pytest.mark.parametrize("variant", ["released", "thesis"])
def test_descriptor_vanishes_on_a_plane_and_fires_at_a_crease(variant):
    points = crease_points(40, 0.0025)
    graph = radius_graph(points, 0.01)
    normals = estimate_normals(points, graph, camera_origin_m=np.array([0, 0, 1.0]))
    values = gradient_descriptor(normals, graph, variant=variant)
    far = np.abs(points[:, 0]) > 0.035
    near = np.abs(points[:, 0]) < 0.01
    assert values[far].max() < 1e-9
    assert values[near].mean() > 1e3 * (values[far].mean() + 1e-12)


def test_stronger_creases_give_larger_values():
    values = []
    for angle in (10, 20, 40):
        points = crease_points(angle, 0.0025)
        graph = radius_graph(points, 0.01)
        normals = estimate_normals(points, graph, camera_origin_m=np.array([0, 0, 1.0]))
        values.append(gradient_descriptor(normals, graph).max())
    assert values[0] < values[1] < values[2]


@pytest.mark.parametrize("variant", ["released", "thesis"])
def test_the_descriptor_and_the_offsets_from_one_pass_are_those_of_two(rng, variant):
    points = crease_points(30, 0.0025)
    points = points + rng.normal(0.0, 0.0002, points.shape)  # noise: sums that round
    graph = radius_graph(points, 0.006)
    normals = estimate_normals(points, graph, camera_origin_m=np.array([0, 0, 1.0]))
    values, offsets = descriptor_and_offsets(points, normals, graph, variant=variant)
    assert np.array_equal(values, gradient_descriptor(normals, graph, variant=variant))  # to the bit
    assert np.array_equal(offsets, centroid_offsets(graph, points))


def test_unknown_variant_is_refused():
    points = crease_points(10, 0.0025)
    with pytest.raises(InputError, match="descriptor.variant"):
        gradient_descriptor(np.tile([0, 0, 1.0], (len(points), 1)), radius_graph(points, 0.01), variant="magic")


def folded(bend_deg, spacing=0.0025, half_extent=0.03):
    """Two half-planes meeting along y: a valley (bend > 0: the right half rises) or a ridge
    (bend < 0), with normals facing +z (a camera above)."""
    ticks = np.arange(-half_extent, half_extent + spacing / 2, spacing)
    u, v = (a.ravel() for a in np.meshgrid(ticks, ticks, indexing="ij"))
    points = np.column_stack([u, v, np.where(u > 0, u * np.tan(np.radians(bend_deg)), 0.0)])
    normals = pca_normals(points, radius_graph(points, 0.006))
    return points, normals * np.where(normals[:, 2:3] < 0, -1.0, 1.0)


@pytest.mark.parametrize("bend_deg", [20.0, 45.0, 90.0])
def test_the_valley_depth_is_positive_in_a_valley_negative_on_a_ridge_and_zero_on_a_plane(bend_deg):
    for sign in (1, -1):
        points, normals = folded(sign * bend_deg)
        depth = valley_depth(centroid_offsets(radius_graph(points, 0.006), points), normals)
        fold = (np.abs(points[:, 0]) < 0.0013) & (np.abs(points[:, 1]) < 0.01)
        inside = (np.abs(points[:, 0]) < 0.022) & (np.abs(points[:, 1]) < 0.022)  # whole neighbourhoods
        far = inside & (np.abs(points[:, 0]) > 0.015)
        # On the fold the neighbours lie ~0.42 r tan(bend / 2) off the tangent plane (r = 6 mm).
        assert sign * np.median(depth[fold]) > 0.2 * 0.006 * np.tan(np.radians(bend_deg / 2))
        assert np.abs(depth[far]).max() < 1e-9
    flat, flat_normals = folded(0.0)
    assert np.abs(valley_depth(centroid_offsets(radius_graph(flat, 0.006), flat), flat_normals)).max() < 1e-9


def test_the_valley_depth_grows_with_the_bend():
    depths = []
    for bend_deg in (20.0, 45.0, 90.0):
        points, normals = folded(bend_deg)
        fold = (np.abs(points[:, 0]) < 0.0013) & (np.abs(points[:, 1]) < 0.01)
        depths.append(np.median(valley_depth(centroid_offsets(radius_graph(points, 0.006), points), normals)[fold]))
    assert depths[0] < depths[1] < depths[2]
