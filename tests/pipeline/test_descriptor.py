import numpy as np
import pytest

from tests.test_pipeline_helpers import crease_points
from weldseam.errors import InputError
from weldseam.pipeline.descriptor import gradient_descriptor
from weldseam.pipeline.neighbours import radius_graph
from weldseam.pipeline.normals import estimate_normals


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


def test_unknown_variant_is_refused():
    points = crease_points(10, 0.0025)
    with pytest.raises(InputError, match="descriptor.variant"):
        gradient_descriptor(np.tile([0, 0, 1.0], (len(points), 1)), radius_graph(points, 0.01), variant="magic")
