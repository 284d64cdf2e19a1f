"""`weldseam config show` and `plan --config`, run as a user would."""

import json
import subprocess
import sys

import numpy as np
import pytest

from tests.conftest import v_groove_cloud
from weldseam.io.clouds import write_ply

CAMERA = "0,0.05,0.45"


def weldseam(*args):
    return subprocess.run([sys.executable, "-m", "weldseam.cli", *map(str, args)], capture_output=True, timeout=120)


@pytest.fixture(scope="module")
def groove_ply(tmp_path_factory):
    path = tmp_path_factory.mktemp("scan") / "groove.ply"
    write_ply(path, v_groove_cloud(np.random.default_rng(3)))
    return path


def test_config_show_prints_toml_that_reads_back_unchanged(tmp_path):
    shown = weldseam("config", "show", "--set", "normals.radius_m=0.008", "--set", "output.rotation=quat")
    assert shown.returncode == 0 and shown.stderr == b""
    text = shown.stdout.decode()
    assert "[normals]\n" in text and "radius_m = 0.008\n" in text and 'rotation = "quat"' in text
    file = tmp_path / "cell.toml"
    file.write_text(text)
    again = weldseam("config", "show", "--config", file)
    assert again.returncode == 0 and again.stdout.decode() == text


def test_config_show_names_a_bad_key_in_one_line(tmp_path):
    file = tmp_path / "cell.toml"
    file.write_text("[normals]\nradius = 0.008\n")
    result = weldseam("config", "show", "--config", file)
    assert result.returncode == 2 and result.stdout == b""
    assert result.stderr.decode() == f"Error: {file}: unknown config key normals.radius\n"


def test_plan_takes_its_parameters_from_the_file_and_the_command_line_wins(groove_ply, tmp_path):
    file = tmp_path / "cell.toml"
    file.write_text('[resample]\nspacing_m = 0.004\n[output]\nformat = "json"\nrotation = "quat"\n')
    from_file = weldseam("plan", groove_ply, "--camera-origin", CAMERA, "--config", file, "-o", "-", "-q")
    assert from_file.returncode == 0, from_file.stderr
    data = json.loads(from_file.stdout)  # output.format = "json" applies to stdout too
    assert data["params"]["resample"]["spacing_m"] == 0.004
    steps = np.diff([[p["x"], p["y"], p["z"]] for p in data["seams"][0]["poses"]], axis=0)
    assert abs(np.median(np.linalg.norm(steps, axis=1)) - 0.004) < 2e-4
    overridden = weldseam(
        "plan", groove_ply, "--camera-origin", CAMERA, "--config", file, "--spacing-mm", "3", "--format", "csv", "-q"
    )
    assert overridden.returncode == 0, overridden.stderr
    assert overridden.stdout.decode().splitlines()[0] == "seam,x,y,z,qx,qy,qz,qw"


def test_plan_with_the_config_of_its_own_output_reproduces_it(groove_ply, tmp_path):
    first = tmp_path / "first.json"
    ran = weldseam(
        "plan", groove_ply, "--camera-origin", CAMERA, "--set", "pairing.max_width_m=0.05", "-o", first, "-q"
    )
    assert ran.returncode == 0, ran.stderr
    second = tmp_path / "second.json"
    rerun = weldseam("plan", groove_ply, "--camera-origin", CAMERA, "--config", first, "-o", second, "-q")
    assert rerun.returncode == 0, rerun.stderr
    a, b = json.loads(first.read_text()), json.loads(second.read_text())
    assert a["params"]["pairing"]["max_width_m"] == 0.05
    assert a["params"] == b["params"] and a["seams"] == b["seams"]


def _memory_cap():
    """At most 2 GB of address space, so that a regression fails fast instead of swapping."""
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))


def test_a_working_voxel_finer_than_the_fine_voxel_is_refused_before_the_scan_is_read(groove_ply, tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "weldseam.cli", "plan", str(groove_ply), "--camera-origin", CAMERA,
         "--set", "condition.working_voxel_m=0.0001", "-o", str(tmp_path / "p.json")],
        capture_output=True, timeout=120, preexec_fn=_memory_cap,
    )
    assert result.returncode == 2 and result.stdout == b""
    assert result.stderr.decode() == (
        "Error: condition.working_voxel_m 0.0001 is below condition.voxel_m 0.001: the working cloud coarsens the "
        "fine one, so its voxel must be at least as large\n"
    )
    assert not (tmp_path / "p.json").exists()
    both = weldseam("config", "show", "--set", "condition.voxel_m=0.0001", "--set", "condition.working_voxel_m=0.0001")
    assert both.returncode == 2
    assert both.stderr.decode().startswith("Error: smooth.radius_m 0.006 spans 60 working voxels")
