"""`plan --direction`: the travel direction is a rule, and copies of one scan that differ by
half a micrometre (a 6-decimal .xyz, 1 % NaN points, a camera-frame copy) all run the same way."""

import json
from pathlib import Path

import numpy as np
import pytest

from tests.test_cli import one_error_line, weldseam
from weldseam.geometry import transform_points
from weldseam.io.clouds import read_cloud
from weldseam.io.paths import read_paths
from weldseam.io.poses import read_camera_pose

SAMPLES = Path(__file__).resolve().parents[1] / "samples"
POSE = SAMPLES / "v_butt.pose.json"


@pytest.fixture(scope="module")
def copies(tmp_path_factory):
    """The v_butt sample and three perturbed copies, with the options that place each."""
    folder = tmp_path_factory.mktemp("copies")
    points = read_cloud(SAMPLES / "v_butt.ply")[0]
    np.savetxt(folder / "rounded.xyz", points, fmt="%.6f")  # 0.5 um rounding
    holes = points.copy()
    holes[np.random.default_rng(0).random(len(holes)) < 0.01] = np.nan
    np.save(folder / "holes.npy", holes)
    np.save(folder / "camera.npy", transform_points(np.linalg.inv(read_camera_pose(POSE)), points))
    return {
        "original": [SAMPLES / "v_butt.ply", "--camera-pose", POSE],
        "rounded": [folder / "rounded.xyz", "--camera-pose", POSE],
        "holes": [folder / "holes.npy", "--camera-pose", POSE],
        "camera": [folder / "camera.npy", "--cloud-frame", "camera", "--camera-pose", POSE],
    }


def planned(tmp_path, scan_options, *extra):
    out = tmp_path / f"path{len(list(tmp_path.iterdir()))}.json"
    result = weldseam("plan", *scan_options, *extra, "-o", out, "-q")
    assert result.returncode == 0, result.stderr
    (path,) = read_paths(out)
    return path, json.loads(out.read_text())


def test_perturbed_copies_of_a_scan_run_the_same_way(copies, tmp_path):
    """The seam lies 7 degrees off y, so under the default +x it runs +y: every copy starts at
    the -y end (before, the .xyz copy ran the other way)."""
    starts = {}
    for name, options in copies.items():
        path, document = planned(tmp_path, options)
        assert document["params"]["direction"]["rule"] == "+x"
        travel = path.positions_m[-1] - path.positions_m[0]
        assert travel[1] > 0.17, name
        steps = np.diff(path.positions_m, axis=0)
        assert (np.sum(steps * path.rotations[:-1, :, 1], axis=1) > 0).all(), name  # tool y along travel
        starts[name] = path.positions_m[0]
    # The same end, to within how far a seam's end moves between copies (its last sections see
    # the plate's end face: ~1-2 mm); the other end is 180 mm away.
    for name, start in starts.items():
        assert np.linalg.norm(start - starts["original"]) < 0.003, name


def test_direction_options_set_the_rule(copies, tmp_path):
    forward, _ = planned(tmp_path, copies["original"])
    backward, document = planned(tmp_path, copies["original"], "--direction=-y")
    assert document["params"]["direction"] == {"rule": "-y", "start_m": None, "closed_sense": "ccw"}
    np.testing.assert_array_equal(backward.positions_m, forward.positions_m[::-1])
    np.testing.assert_allclose(backward.rotations[:, :, 2], forward.rotations[::-1, :, 2], atol=1e-9)
    near_end = forward.positions_m[-1] + [0.0, 0.05, 0.0]
    from_point, document = planned(tmp_path, copies["original"], "--direction", ",".join(map(str, near_end)))
    assert document["params"]["direction"]["rule"] == "start-point"
    np.testing.assert_array_equal(from_point.positions_m, backward.positions_m)
    in_config, _ = planned(tmp_path, copies["original"], "--set", 'direction.rule="-y"')
    np.testing.assert_array_equal(in_config.positions_m, backward.positions_m)


@pytest.mark.parametrize("options, message", [
    (["--direction", "north"], "--direction: expected +x, -x, +y, -y, +z, -z, away-from-robot, toward-robot or a "
                               "start point x,y,z (m), got 'north'"),
    (["--set", 'direction.rule="start-point"'], "direction.start_m must be given with direction.rule start-point"),
])
def test_a_bad_direction_is_one_line(copies, tmp_path, options, message):
    result = weldseam("plan", *copies["original"], *options, "-o", tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, message)
