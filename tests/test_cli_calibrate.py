"""`weldseam calibrate hand-eye`, run through the real Typer app on synthetic capture sets."""

import json
import shutil
import subprocess
import sys

import cv2
import numpy as np
import pytest
import typer
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from weldseam.commands.calibrate import calibrate_app
from weldseam.synthetic.board import CHARUCO, CHESSBOARD, hand_eye_captures, write_capture_set

app = typer.Typer(rich_markup_mode=None)
app.add_typer(calibrate_app, name="calibrate")


@app.callback()
def _root() -> None:
    """The weldseam root, as cli.py mounts calibrate_app."""


def weldseam(*args):
    return CliRunner().invoke(app, [str(arg) for arg in args])


@pytest.fixture(scope="module")
def eye_in_hand(tmp_path_factory):
    """Chessboard on the table, camera on the flange; robot poses given as UR5 joint angles."""
    captures = hand_eye_captures(CHESSBOARD, "eye-in-hand", count=10, seed=5)
    return write_capture_set(tmp_path_factory.mktemp("eye_in_hand"), captures, joints=True), captures.hand_eye


@pytest.fixture(scope="module")
def eye_to_hand(tmp_path_factory):
    """ChArUco board on the flange, camera over the cell; robot poses given as UR pose vectors."""
    captures = hand_eye_captures(CHARUCO, "eye-to-hand", count=10, seed=6)
    return write_capture_set(tmp_path_factory.mktemp("eye_to_hand"), captures), captures.hand_eye


@pytest.fixture
def capture_copy(eye_in_hand, tmp_path):
    """A private copy of the eye-in-hand set, to break."""
    directory = shutil.copytree(eye_in_hand[0].parent, tmp_path / "set")
    return directory / "manifest.json"


def edit_manifest(path, change):
    manifest = json.loads(path.read_text())
    change(manifest)
    path.write_text(json.dumps(manifest))


def assert_near(matrix, truth, mm=1.0, deg=0.2):
    matrix = np.array(matrix)
    assert np.linalg.norm(matrix[:3, 3] - truth[:3, 3]) * 1000 < mm
    assert np.degrees(Rotation.from_matrix(matrix[:3, :3].T @ truth[:3, :3]).magnitude()) < deg


def test_eye_in_hand_from_joint_angles_writes_T_flange_camera(eye_in_hand, tmp_path):
    manifest, truth = eye_in_hand
    result = weldseam("calibrate", "hand-eye", manifest, "-o", tmp_path / "H.json")
    assert result.exit_code == 0, result.stderr
    document = json.loads((tmp_path / "H.json").read_text())
    assert document["setup"] == "eye-in-hand" and document["captures"] == 10
    assert_near(document["T_flange_camera"], truth)
    lines = result.stderr.splitlines()
    assert lines[0].split() == ["method", "error", "mm", "error", "deg", "scatter", "mm", "scatter", "deg", "corners",
                                "mm"]  # fmt: skip
    chosen = [line for line in lines if line.endswith("<- chosen")]
    assert len(chosen) == 1 and chosen[0].startswith(document["method"])
    error = document["residuals"]["leave_one_out"]
    assert lines[-1].startswith(
        f"{tmp_path / 'H.json'}: eye-in-hand, {document['method']}, 10 captures; estimated error "
        f"{error['translation_mm']:.2f} mm / {error['rotation_deg']:.3f} deg (leave-one-out); board scatter "
    )
    assert float(chosen[0].split()[1]) == pytest.approx(error["translation_mm"], abs=5e-4)
    assert result.stdout == ""


def test_eye_to_hand_with_charuco_writes_T_base_camera(eye_to_hand, tmp_path):
    manifest, truth = eye_to_hand
    result = weldseam("calibrate", "hand-eye", manifest, "-o", tmp_path / "H.json", "-q")
    assert result.exit_code == 0, result.stderr
    document = json.loads((tmp_path / "H.json").read_text())
    assert document["setup"] == "eye-to-hand" and "T_flange_camera" not in document
    assert_near(document["T_base_camera"], truth)
    assert result.stderr == ""


def test_the_output_is_byte_identical_across_runs(eye_to_hand, tmp_path):
    for name in ("a.json", "b.json"):
        assert weldseam("calibrate", "hand-eye", eye_to_hand[0], "-o", tmp_path / name, "-q").exit_code == 0
    assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()


def test_json_table_on_stdout_and_a_chosen_method(eye_in_hand, tmp_path):
    result = weldseam("calibrate", "hand-eye", eye_in_hand[0], "-o", tmp_path / "H.json", "--json", "--method", "tsai")
    assert result.exit_code == 0, result.stderr
    table = json.loads(result.stdout)
    assert table["method"] == "tsai" and table["captures"] == 10 and table["max_reprojection_px"] < 0.5
    assert [row["method"] for row in table["methods"]] == ["tsai", "park", "horaud", "andreff", "daniilidis"]
    assert [row["chosen"] for row in table["methods"]] == [True, False, False, False, False]
    document = json.loads((tmp_path / "H.json").read_text())
    assert document["method"] == "tsai"
    assert document["residuals"]["per_method"]["park"] == {
        key: value for key, value in table["methods"][1].items() if key not in ("method", "chosen")
    }


def test_the_hand_eye_file_can_go_to_stdout(eye_in_hand):
    result = weldseam("calibrate", "hand-eye", eye_in_hand[0], "-o", "-", "-q")
    assert result.exit_code == 0, result.stderr
    assert_near(json.loads(result.stdout)["T_flange_camera"], eye_in_hand[1])


def run_refused(manifest, tmp_path, *extra):
    """Exit 2 with exactly one `Error:` line, and no output file."""
    result = weldseam("calibrate", "hand-eye", manifest, "-o", tmp_path / "H.json", *extra)
    assert result.exit_code == 2, result.stdout + result.stderr
    assert len(result.stderr.splitlines()) == 1 and result.stderr.startswith("Error: ")
    assert not (tmp_path / "H.json").exists()
    return result.stderr.strip()


def test_a_board_not_found_names_the_image(capture_copy, tmp_path):
    blank = capture_copy.parent / "cap03.png"
    cv2.imwrite(str(blank), np.full((480, 640), 128, np.uint8))
    assert run_refused(capture_copy, tmp_path) == (
        f"Error: {blank} (capture 3): chessboard 9x6 (inner corners) not found in the image "
        "(the whole board must be in view, sharp and not too oblique)"
    )


def test_an_unreadable_or_missing_image_names_the_file(capture_copy, tmp_path):
    (capture_copy.parent / "cap02.png").write_bytes(b"not a png")
    assert run_refused(capture_copy, tmp_path) == (
        f"Error: {capture_copy.parent / 'cap02.png'}: not a readable image (PNG, JPEG, BMP, TIFF)"
    )
    (capture_copy.parent / "cap02.png").unlink()
    assert run_refused(capture_copy, tmp_path) == f"Error: {capture_copy.parent / 'cap02.png'}: no such file"


def test_an_image_of_another_size_than_the_intrinsics_is_refused(capture_copy, tmp_path):
    cv2.imwrite(str(capture_copy.parent / "cap04.png"), np.zeros((240, 320), np.uint8))
    assert run_refused(capture_copy, tmp_path).endswith("cap04.png: image is 320x240 but the intrinsics say 640x480")


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda m: m.pop("board"), "missing key board (see weldseam calibrate hand-eye --help)"),
        (lambda m: m.update(setup="eye-on-hand"), "setup must be eye-in-hand or eye-to-hand, got 'eye-on-hand'"),
        (lambda m: m["captures"][1].pop("image"), 'captures[1]: missing key "image" (the image file name)'),
        (lambda m: m["captures"][0].pop("joints_rad"), 'captures[0]: give exactly one of "flange_pose"'),
        (lambda m: m["captures"][2].update(joints_rad=[1, 2, 3]), "captures[2]: joints_rad must be a list of 6"),
        (lambda m: m["captures"][2].update(joints_rad=[90, 0, 0, 0, 0, 0]), "look like degrees; give radians"),
        (lambda m: m.update(board={"type": "chessboard", "columns": 9, "rows": 7, "square_mm": 20}),
         "board: a chessboard of 9x7 inner corners looks the same turned by 180 degrees"),
        (lambda m: m.update(distortion=[0.1, 0.2]), "distortion must be a list of 4, 5, 8, 12 or 14 numbers"),
        (lambda m: m.update(captures=m["captures"][:2]), "needs at least 6 captures (to check the answer by leaving each out), got 2; take 10-20"),
    ],
)
def test_bad_manifests_are_one_line_naming_the_file_and_the_problem(capture_copy, tmp_path, change, message):
    edit_manifest(capture_copy, change)
    error = run_refused(capture_copy, tmp_path)
    assert error.startswith(f"Error: {capture_copy}: ") and message in error


def test_millimetre_flange_poses_are_refused(eye_to_hand, tmp_path):
    manifest = shutil.copytree(eye_to_hand[0].parent, tmp_path / "set") / "manifest.json"
    edit_manifest(manifest, lambda m: m["captures"][0].update(flange_pose=[400, -100, 500, 0, 3.1, 0]))
    assert run_refused(manifest, tmp_path).endswith(
        "captures[0]: flange_pose [400.0, -100.0, 500.0] looks like millimetres; UR pose vectors are in metres"
    )


def test_captures_turning_about_one_axis_are_refused(eye_to_hand, tmp_path):
    manifest = shutil.copytree(eye_to_hand[0].parent, tmp_path / "set") / "manifest.json"

    def about_base_z(document):
        for index, capture in enumerate(document["captures"]):
            capture["flange_pose"][3:] = [0.0, 0.0, 0.3 * index]

    edit_manifest(manifest, about_base_z)
    assert run_refused(manifest, tmp_path).startswith(
        f"Error: {manifest}: all 10 captures turn the flange about one axis (base frame direction 0.00,0.00,1.00,"
    )


def test_unknown_method_and_json_on_both_streams_are_refused(eye_in_hand, tmp_path):
    assert run_refused(eye_in_hand[0], tmp_path, "--method", "best") == (
        "Error: --method best: expected auto, tsai, park, horaud, andreff, daniilidis"
    )
    result = weldseam("calibrate", "hand-eye", eye_in_hand[0], "-o", "-", "--json")
    assert result.exit_code == 2 and "both want stdout" in result.stderr


def test_help_shows_an_example_and_the_manifest_format():
    result = weldseam("calibrate", "hand-eye", "--help")
    assert result.exit_code == 0
    assert "Example:" in result.stdout and "weldseam calibrate hand-eye calib/manifest.json" in result.stdout
    assert '"flange_pose": [x, y, z, rx, ry, rz]' in result.stdout and "T_flange_camera" in result.stdout


def test_the_readme_example_runs_on_a_generated_capture_set(tmp_path):
    generated = subprocess.run([sys.executable, "-m", "weldseam.synthetic.board", "calib", "eye-to-hand", "charuco"],
                               cwd=tmp_path, capture_output=True, text=True, timeout=120)  # fmt: skip
    assert generated.returncode == 0, generated.stderr
    assert generated.stdout.strip() == "calib/manifest.json"
    result = weldseam("calibrate", "hand-eye", tmp_path / "calib/manifest.json", "-o", tmp_path / "H.json", "-q")
    assert result.exit_code == 0, result.stderr
    truth = json.loads((tmp_path / "calib/truth.json").read_text())
    assert_near(json.loads((tmp_path / "H.json").read_text())["T_base_camera"], np.array(truth["T_base_camera"]))


@pytest.mark.parametrize("setup", ["eye_in_hand", "eye_to_hand"])
def test_the_file_written_is_the_one_plan_reads(setup, request, tmp_path):
    """calibrate's output goes straight into `plan --hand-eye`: read_hand_eye accepts it unchanged."""
    from weldseam.io.hand_eye import read_hand_eye

    manifest, truth = request.getfixturevalue(setup)
    output = tmp_path / "H.json"
    result = weldseam("calibrate", "hand-eye", manifest, "-o", output, "-q")
    assert result.exit_code == 0, result.output
    hand_eye = read_hand_eye(output)
    assert hand_eye.setup == setup.replace("_", "-")
    assert_near(hand_eye.transform, truth)


def run_cli(*args):
    """The installed command in a process of its own: what reaches file descriptor 2 is what the user sees."""
    return subprocess.run([sys.executable, "-m", "weldseam.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=120)  # fmt: skip


@pytest.mark.parametrize("count", [3, 4])
def test_three_or_four_captures_are_refused_before_any_image_is_read(capture_copy, tmp_path, count):
    """3 captures were accepted with 0.51 mm board scatter while the transform was 5.3 mm / 0.8 deg off."""
    edit_manifest(capture_copy, lambda m: m.update(captures=m["captures"][:count]))
    (capture_copy.parent / "cap01.png").write_bytes(b"not read")
    result = run_cli("calibrate", "hand-eye", capture_copy, "-o", tmp_path / "H.json")
    assert result.returncode == 2
    assert result.stderr == (
        f"Error: {capture_copy}: hand-eye calibration needs at least 6 captures (to check the answer by leaving "
        f"each out), got {count}; take 10-20, and tilt the flange by 15-30 deg about at least two different axes "
        "between captures\n"
    )


def test_opencv_lines_about_a_broken_image_stay_out_of_the_terminal(capture_copy, tmp_path):
    image = capture_copy.parent / "cap03.png"
    image.write_bytes(image.read_bytes()[:3000])  # OpenCV: "[ WARN...] PNG input buffer is incomplete"
    result = run_cli("calibrate", "hand-eye", capture_copy, "-o", tmp_path / "H.json")
    assert result.returncode == 2
    assert result.stderr == f"Error: {image}: not a readable image (PNG, JPEG, BMP, TIFF)\n"


def test_the_help_states_the_capture_rule():
    text = " ".join(weldseam("calibrate", "hand-eye", "--help").stdout.split())
    assert "Refused, before any image is read: fewer than 6 captures;" in text
    assert "a set that breaks either rule once any one capture is left out" in text
