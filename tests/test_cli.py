"""The real `weldseam` command, run as a user would: exit codes, stdout, stderr, files."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.conftest import v_groove_cloud
from weldseam.config import PlanConfig
from weldseam.io.clouds import write_ply

CAMERA = "0,0.05,0.45"
SAMPLES = Path(__file__).resolve().parents[1] / "samples"


def weldseam(*args, stdin: bytes | None = None):
    return subprocess.run(
        [sys.executable, "-m", "weldseam.cli", *map(str, args)], input=stdin, capture_output=True, timeout=120
    )


@pytest.fixture(scope="module")
def groove_ply(tmp_path_factory):
    path = tmp_path_factory.mktemp("scan") / "groove.ply"
    write_ply(path, v_groove_cloud(np.random.default_rng(7)))
    return path


def one_error_line(result, *fragments):
    lines = result.stderr.decode().strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("Error: ")
    for fragment in fragments:
        assert fragment in lines[0]
    return lines[0]


def test_plan_writes_a_json_path_on_the_groove(groove_ply, tmp_path):
    out = tmp_path / "path.json"
    result = weldseam("plan", groove_ply, "--camera-origin", CAMERA, "-o", out)
    assert result.returncode == 0, result.stderr
    assert result.stdout == b""  # data only when asked for on stdout
    assert "1 seam(s)" in result.stderr.decode()
    data = json.loads(out.read_text())
    assert data["frame"] == "base" and data["units"] == "m"
    assert data["input"]["sha256"] and data["input"]["points"] > 50000
    assert data["params"]["normals"]["radius_m"] == PlanConfig().normals.radius_m
    (seam,) = data["seams"]
    poses = np.array([[p["x"], p["y"], p["z"]] for p in seam["poses"]])
    assert np.abs(poses[:, 1]).mean() < 0.0005 and np.abs(poses[:, 2] - 0.010).mean() < 0.0005


def test_csv_on_stdout_from_a_ply_on_stdin_is_deterministic(groove_ply):
    first = weldseam("plan", "-", "--camera-origin", CAMERA, "-q", stdin=groove_ply.read_bytes())
    second = weldseam("plan", groove_ply, "--camera-origin", CAMERA, "-o", "-", "--format", "csv", "-q")
    assert first.returncode == 0 and second.returncode == 0
    assert first.stderr == b""
    lines = first.stdout.decode().splitlines()
    assert lines[0] == "seam,x,y,z,rx,ry,rz" and len(lines) > 100
    assert first.stdout == second.stdout


def test_json_output_is_byte_identical_apart_from_timings(groove_ply, tmp_path):
    outputs = []
    for name in ("a.json", "b.json"):
        assert weldseam("plan", groove_ply, "--camera-origin", CAMERA, "-o", tmp_path / name).returncode == 0
        data = json.loads((tmp_path / name).read_text())
        data.pop("timings_s")
        outputs.append(json.dumps(data))
    assert outputs[0] == outputs[1]


def test_dump_stages_writes_each_stage_as_ply(groove_ply, tmp_path):
    result = weldseam("plan", groove_ply, "--camera-origin", CAMERA, "-o", tmp_path / "p.csv", "--dump-stages", tmp_path / "dump")
    assert result.returncode == 0
    names = sorted(p.name for p in (tmp_path / "dump").iterdir())
    assert names[0] == "000_condition.ply" and any("descriptor" in n for n in names) and names[-1].endswith("_resample.ply")


def test_a_flat_plate_exits_3_and_writes_nothing_unless_allowed(tmp_path):
    rng = np.random.default_rng(3)
    grid = np.stack(np.meshgrid(np.arange(0, 0.2, 0.0008), np.arange(0, 0.15, 0.0008)), -1).reshape(-1, 2)
    plate = tmp_path / "plate.npy"
    np.save(plate, np.column_stack([grid, rng.normal(0, 0.0003, len(grid))]))
    out = tmp_path / "path.csv"
    result = weldseam("plan", plate, "--camera-origin", "0.1,0.07,0.45", "-o", out)
    assert result.returncode == 3
    one_error_line(result, "no weld seam found", "plate.npy")
    assert not out.exists()
    allowed = weldseam("plan", plate, "--camera-origin", "0.1,0.07,0.45", "-o", out, "--allow-empty")
    assert allowed.returncode == 0 and out.read_text() == "seam,x,y,z,rx,ry,rz\n"


def _truncated_ply(tmp_path, groove_ply):
    path = tmp_path / "cut.ply"
    path.write_bytes(groove_ply.read_bytes()[:5000])
    return path


def _empty_ply(tmp_path, _):
    path = tmp_path / "empty.ply"
    path.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
    return path


def _nan_cloud(tmp_path, _):
    path = tmp_path / "nan.npy"
    np.save(path, np.full((100, 3), np.nan))
    return path


def _mm_cloud(tmp_path, groove_ply):
    path = tmp_path / "mm.npy"
    np.save(path, v_groove_cloud(np.random.default_rng(1)) * 1000.0)
    return path


@pytest.mark.parametrize(
    "make, extra, fragments",
    [
        (lambda tmp, _: tmp / "missing.ply", [], ["missing.ply", "no such file"]),
        (_truncated_ply, [], ["cut.ply"]),
        (_empty_ply, [], ["empty.ply", "no points"]),
        (_nan_cloud, [], ["nan.npy", "NaN"]),
        (_mm_cloud, [], ["mm.npy", "--units mm"]),
    ],
)
def test_bad_clouds_exit_2_with_one_line_and_no_output(groove_ply, tmp_path, make, extra, fragments):
    scan = make(tmp_path, groove_ply)
    out = tmp_path / "out.json"
    result = weldseam("plan", scan, "--camera-origin", CAMERA, "-o", out, *extra)
    assert result.returncode == 2
    one_error_line(result, *fragments)
    assert not out.exists()


def test_a_millimetre_cloud_plans_with_units_mm(tmp_path):
    path = tmp_path / "mm.npy"
    np.save(path, v_groove_cloud(np.random.default_rng(1)) * 1000.0)
    result = weldseam("plan", path, "--units", "mm", "--camera-origin", CAMERA, "-o", tmp_path / "p.csv")
    assert result.returncode == 0, result.stderr


@pytest.fixture
def depth_png(tmp_path):
    path = tmp_path / "depth.png"
    Image.fromarray(np.full((48, 64), 450, np.uint16)).save(path)
    return path


def write_intrinsics(tmp_path, width=64, height=48):
    path = tmp_path / "intrinsics.json"
    path.write_text(json.dumps(dict(width=width, height=height, fx=60.0, fy=60.0, ppx=32.0, ppy=24.0, depth_scale=1000)))
    return path


def test_depth_png_errors(tmp_path, depth_png):
    out = tmp_path / "out.json"
    no_intrinsics = weldseam("plan", depth_png, "-o", out)
    assert no_intrinsics.returncode == 2
    one_error_line(no_intrinsics, "depth.png", "--intrinsics")
    mismatch = weldseam("plan", depth_png, "--intrinsics", write_intrinsics(tmp_path, width=640, height=480), "-o", out)
    assert mismatch.returncode == 2
    one_error_line(mismatch, "depth.png", "64x48", "640x480")
    eight_bit = tmp_path / "gray.png"
    Image.fromarray(np.full((48, 64), 200, np.uint8)).save(eight_bit)
    result = weldseam("plan", eight_bit, "--intrinsics", write_intrinsics(tmp_path), "-o", out)
    assert result.returncode == 2
    one_error_line(result, "gray.png", "16-bit")
    assert not out.exists()


def test_every_command_help_has_an_example_and_the_exit_codes():
    result = weldseam("plan", "--help")
    text = result.stdout.decode()
    assert result.returncode == 0 and "Example" in text and "3: no weld seam found" in text


def test_bad_set_option_names_the_key(groove_ply):
    result = weldseam("plan", groove_ply, "--set", "normals.radius=0.01")
    assert result.returncode == 2
    one_error_line(result, "normals.radius")


def test_crop_box_keeps_the_seam_inside_it(groove_ply, tmp_path):
    out = tmp_path / "path.csv"
    result = weldseam("plan", groove_ply, "--camera-origin", CAMERA, "--crop=-0.05,-0.1,-0.1,0.05,0.1,0.1", "-o", out)
    assert result.returncode == 0, result.stderr
    x = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1]
    assert x.min() >= -0.051 and x.max() <= 0.051 and np.ptp(x) > 0.09
    bad = weldseam("plan", groove_ply, "--crop=0.1,0,0,0,1,1", "-o", tmp_path / "bad.csv")
    assert bad.returncode == 2
    one_error_line(bad, "--crop")


@pytest.fixture(scope="module")
def flat_plate(tmp_path_factory):
    """A plate with no seam: planning it ends in exit 3 only after the whole pipeline has run."""
    rng = np.random.default_rng(3)
    grid = np.stack(np.meshgrid(np.arange(0, 0.2, 0.0008), np.arange(0, 0.15, 0.0008)), -1).reshape(-1, 2)
    plate = tmp_path_factory.mktemp("plate") / "plate.npy"
    np.save(plate, np.column_stack([grid, rng.normal(0, 0.0003, len(grid))]))
    return plate


def _unwritable_folder():
    """/sys refuses new files even to root (chmod does not stop root)."""
    import os
    import secrets

    folder = Path("/sys")
    probe = folder / f"weldseam-{secrets.token_hex(4)}"
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL))
    except OSError:
        return folder
    probe.unlink()
    pytest.skip("no unwritable folder here")


@pytest.mark.parametrize("option, target, fragment", [
    ("-o", "missing/path.json", "the folder {tmp}/missing does not exist"),
    ("-o", "file.txt/path.json", "{tmp}/file.txt is a file, not a folder"),
    ("-o", "path.txt", "unknown path file format '.txt'"),
    ("-o", "out.json", "{tmp}/out.json: is a folder, not a file name"),
    ("--report", "missing/r.html", "the folder {tmp}/missing does not exist"),
    ("--dump-stages", "file.txt", "{tmp}/file.txt: is a file, not a folder"),
    ("--dump-stages", "file.txt/dump", "cannot create the folder"),
])
def test_a_bad_output_is_one_line_exit_2_before_the_pipeline_runs(flat_plate, tmp_path, option, target, fragment):
    (tmp_path / "file.txt").write_text("not a folder")
    (tmp_path / "out.json").mkdir()
    extra = [] if option == "-o" else ["-o", tmp_path / "p.json"]
    result = weldseam("plan", flat_plate, "--camera-origin", "0.1,0.07,0.45", option, tmp_path / target, *extra)
    assert result.returncode == 2  # not 3: the plate's "no seam" would come after the whole pipeline
    one_error_line(result, fragment.format(tmp=tmp_path))
    assert sorted(path.name for path in tmp_path.iterdir()) == ["file.txt", "out.json"]


@pytest.mark.parametrize("option", ["-o", "--report", "--dump-stages"])
def test_an_unwritable_folder_is_one_line_exit_2_before_the_pipeline_runs(flat_plate, tmp_path, option):
    folder = _unwritable_folder()
    target = folder / ("dump" if option == "--dump-stages" else "out.json" if option == "-o" else "r.html")
    extra = [] if option == "-o" else ["-o", tmp_path / "p.json"]
    result = weldseam("plan", flat_plate, "--camera-origin", "0.1,0.07,0.45", option, target, *extra)
    assert result.returncode == 2
    line = one_error_line(result, str(target))
    assert "cannot" in line and "Traceback" not in result.stderr.decode()
    assert not (tmp_path / "p.json").exists()



@pytest.mark.parametrize("depth_scale, median", [(1.0, "438 m"), (1e6, "0.000438 m")])
def test_a_depth_scale_wrong_by_1000_says_what_to_pass(tmp_path, depth_scale, median):
    intrinsics = json.loads((SAMPLES / "d415.intrinsics.json").read_text())
    intrinsics["depth_scale"] = depth_scale
    path = tmp_path / "i.json"
    path.write_text(json.dumps(intrinsics))
    result = weldseam("plan", SAMPLES / "fillet_t.png", "--intrinsics", path, "-o", tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, f"fillet_t.png: the median depth is {median} with depth_scale {depth_scale:g} (units "
                           f"per metre, {path}), not a depth camera's 0.05-10 m: depth_scale 1000 gives 0.438 m")


@pytest.fixture(scope="module")
def camera_frame_cloud(tmp_path_factory):
    """The v_butt sample as its camera saw it: in the camera frame."""
    from weldseam.geometry import transform_points
    from weldseam.io.clouds import read_cloud
    from weldseam.io.poses import read_camera_pose

    path = tmp_path_factory.mktemp("camera") / "seen.npy"
    T_base_camera = read_camera_pose(SAMPLES / "v_butt.pose.json")
    np.save(path, transform_points(np.linalg.inv(T_base_camera), read_cloud(SAMPLES / "v_butt.ply")[0]))
    return path


def test_a_camera_frame_cloud_given_as_base_with_its_pose_is_refused(camera_frame_cloud, tmp_path):
    result = weldseam("plan", camera_frame_cloud, "--camera-pose", SAMPLES / "v_butt.pose.json", "-o",
                      tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, f"{camera_frame_cloud}: only 1% of the points lie in front of the camera its pose places",
                   "pass --cloud-frame camera")
    placed = weldseam("plan", camera_frame_cloud, "--cloud-frame", "camera", "--camera-pose",
                      SAMPLES / "v_butt.pose.json", "-o", tmp_path / "p.json", "-q")
    assert placed.returncode == 0, placed.stderr


def test_a_camera_frame_cloud_without_a_pose_is_seen_from_its_origin_and_gets_a_hint(camera_frame_cloud, tmp_path):
    # Its normals face its origin, where the camera was: the groove is found where it is in the
    # cloud's own frame, and the user is told how to place it.
    from scipy.spatial import cKDTree

    from weldseam.geometry import transform_points
    from weldseam.io.paths import read_paths
    from weldseam.io.poses import read_camera_pose

    result = weldseam("plan", camera_frame_cloud, "-o", tmp_path / "p.json")
    assert result.returncode == 0, result.stderr.decode()
    assert f"{camera_frame_cloud} looks like a camera-frame cloud" in result.stderr.decode()
    assert "pass --cloud-frame camera with --camera-pose" in result.stderr.decode()
    truth = json.loads((SAMPLES / "v_butt.truth.json").read_text())["seams"][0]["points_m"]
    seen = transform_points(np.linalg.inv(read_camera_pose(SAMPLES / "v_butt.pose.json")), np.array(truth))
    (path,) = read_paths(tmp_path / "p.json")
    assert cKDTree(seen).query(path.positions_m)[0].mean() <= 0.0005
    explicit = weldseam("plan", camera_frame_cloud, "--cloud-frame", "base", "-o", tmp_path / "p.json")
    assert "looks like" not in explicit.stderr.decode()  # the user said base: normals toward +z, no hint


def test_a_base_frame_cloud_is_not_taken_for_a_camera_frame_one(groove_ply):
    from weldseam.io.scan import camera_frame_hint
    from weldseam.types import Scan

    assert camera_frame_hint(Scan(v_groove_cloud(np.random.default_rng(1)), source="groove")) is None
    lifted = v_groove_cloud(np.random.default_rng(1)) + [0.0, 0.0, 0.4]  # as a camera 0.4 m above would see it
    assert camera_frame_hint(Scan(lifted, source="lifted")).startswith("lifted looks like a camera-frame cloud")
