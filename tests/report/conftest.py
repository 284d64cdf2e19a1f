import numpy as np
import pytest

from weldseam.geometry import frames_from_axes
from weldseam.types import WeldPath


@pytest.fixture(scope="module")
def plate_and_path():
    """A 200 x 100 mm plate with a straight seam along x at its centre, torch straight down."""
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.uniform(-0.1, 0.1, 50000), rng.uniform(-0.05, 0.05, 50000), rng.normal(0, 2e-4, 50000)])
    x = np.arange(-0.08, 0.0801, 0.002)
    positions = np.column_stack([x, np.zeros_like(x), np.full_like(x, 0.001)])
    rotations = frames_from_axes(np.tile([0.0, 0.0, -1.0], (len(x), 1)), np.tile([1.0, 0.0, 0.0], (len(x), 1)))
    record = {
        "seams": [{"id": 0, "joint": "v_groove", "length_m": 0.16, "confidence": 0.9, "closed": False, "poses": [{}] * len(x)}],
        "timings_s": {"condition": 0.1, "section": 0.2},
        "warnings": ["a warning <b>escaped</b>"],
        "params": {"normals": {"radius_m": 0.006}},
        "input": {"path": "plate.ply", "points": 50000, "sha256": "abc"},
    }
    return points, [WeldPath(0, positions, rotations, joint="v_groove")], record


@pytest.fixture(scope="module")
def rng_points_60k(plate_and_path):
    """The plate at 120k points: more than the default point budget."""
    _, paths, record = plate_and_path
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(-0.1, 0.1, 120000), rng.uniform(-0.05, 0.05, 120000),
                              rng.normal(0, 2e-4, 120000)])  # fmt: skip
    return points, paths, record


@pytest.fixture(scope="module")
def unsure_path(plate_and_path):
    """The plate's path with poses 20-29 interpolated across a hole (0.3) and 50-54 with one face
    unseen (0.7), and its record as the path JSON writes it."""
    from dataclasses import replace

    points, (path,), record = plate_and_path
    confidence = np.ones(len(path.positions_m))
    confidence[20:30], confidence[50:55] = 0.3, 0.7
    seam = {**record["seams"][0], "poses": [{"confidence": c} for c in confidence.tolist()]}
    return points, replace(path, pose_confidence=confidence), {**record, "seams": [seam]}
