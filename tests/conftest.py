"""Shared analytic test geometry: clouds whose seam line is known exactly."""

import signal

import numpy as np
import pytest


def pytest_configure(config):
    """Ctrl-C tests send SIGINT to child processes. A test run started in the background of a
    non-interactive shell (`.ci/run &`) inherits SIGINT ignored, and an ignored signal stays
    ignored in every child across exec, so those children could not be interrupted at all.
    Handled here (as an interactive run has it), SIGINT reaches each child at its default."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def v_groove_cloud(
    rng, *, thickness_m=0.010, included_deg=70.0, gap_m=0.001, noise_m=0.0003, pitch_m=0.0007,
    length_m=0.24, plate_half_width_m=0.08,
):
    """Two bevelled plates on a table, groove along x at y = 0; the seam (centre of the
    opening at the surface) is the line y = 0, z = thickness_m. Returns (N, 3) points."""
    xs = np.arange(-length_m / 2, length_m / 2, pitch_m)
    ys = np.arange(-0.1, 0.1, pitch_m)
    x, y = (a.ravel() for a in np.meshgrid(xs, ys))
    half = np.radians(included_deg / 2)
    half_open = gap_m / 2 + thickness_m * np.tan(half)
    z = thickness_m - np.clip((half_open - np.abs(y)) / np.tan(half), 0.0, thickness_m)
    z = np.where(np.abs(y) > plate_half_width_m, 0.0, z)
    keep = np.abs(y) >= gap_m / 2
    points = np.column_stack([x[keep], y[keep], z[keep]])
    points[:, 2] += rng.normal(0.0, noise_m, len(points))
    return points


def fillet_cloud(rng, *, web_height_m=0.05, flange_m=0.01, noise_m=0.0003, pitch_m=0.0007):
    """An inside corner as a camera at (0, 0.3, 0.3) sees it: a vertical web face at y = 0
    (facing +y, x along the seam) standing on a flange (top at z = 0, 0 < y < 80 mm) that
    lies on a table (z = -flange_m, y > 80 mm). The seam is the corner line y = 0, z = 0;
    the torch axis bisects the faces: (0, -1, -1) / sqrt(2)."""
    xs = np.arange(-0.1, 0.1, pitch_m)
    x, y = (a.ravel() for a in np.meshgrid(xs, np.arange(pitch_m / 2, 0.16, pitch_m)))
    flange = np.column_stack([x, y, np.where(y < 0.08, 0.0, -flange_m)])
    xs_edge, zs_edge = (a.ravel() for a in np.meshgrid(xs, np.arange(-flange_m, 0.0, pitch_m)))
    flange_edge = np.column_stack([xs_edge, np.full_like(xs_edge, 0.08), zs_edge])
    xw, zw = (a.ravel() for a in np.meshgrid(xs, np.arange(pitch_m / 2, web_height_m, pitch_m)))
    web = np.column_stack([xw, np.zeros_like(xw), zw])
    points = np.vstack([flange, flange_edge, web])
    return points + rng.normal(0.0, noise_m, points.shape)


def rotation_about(axis, angle_rad):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle_rad) * k + (1 - np.cos(angle_rad)) * k @ k


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


def planned_broad_case(family: str, seed: int, last: str):
    """(scene, state) of the project's own broad-world case `family`, `seed`, run through the
    pipeline up to the step `last` with the default settings."""
    from weldseam.config import PlanConfig
    from weldseam.pipeline.run import run_steps
    from weldseam.synthetic.catalog import draw_case
    from weldseam.types import Scan

    scene, scan = draw_case(family, seed, broad=True)
    source = f"{family}_{seed}"
    return scene, run_steps(Scan(points_m=scan.points_m, camera_origin_m=scan.camera_origin_m, source=source),
                            PlanConfig(), last=last)  # fmt: skip


def rejected_gaps_to_fixtures_m(scene, state, rejection) -> list[float]:
    """For each candidate a run rejected for `rejection`, the distance (m) from its centre to the
    nearest of the scene's fixtures' bounding boxes."""
    centres = [np.array(c.centre_m) for c in state.chain_candidates if c.rejection == rejection]
    return [min(float(np.linalg.norm(np.maximum(0.0, np.maximum(f.bounds[0] - centre, centre - f.bounds[1]))))
                for f in scene.fixtures) for centre in centres]  # fmt: skip
