"""AX = XB against known hand-eye transforms: exact synthetic poses, rendered captures with noise, and the
captures the solver must refuse."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from weldseam.calibration.board import camera_matrix, detect_board, estimate_board_pose
from weldseam.calibration.handeye import (
    METHODS,
    board_scatter,
    calibrate_hand_eye,
    fixed_board_poses,
)
from weldseam.errors import InputError
from weldseam.synthetic.board import (
    CHARUCO,
    CHESSBOARD,
    T_BASE_CAMERA,
    T_FLANGE_CAMERA,
    hand_eye_captures,
)
from weldseam.synthetic.sensor import D415

BOARDS = {"chessboard": CHESSBOARD, "charuco": CHARUCO}


def transform(rotvec_deg, translation_m):
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_rotvec(np.radians(rotvec_deg)).as_matrix()
    matrix[:3, 3] = translation_m
    return matrix


def hand_eye_error(estimated, truth):
    """Translation (mm) and rotation (deg) between two transforms."""
    angle = Rotation.from_matrix(estimated[:3, :3].T @ truth[:3, :3]).magnitude()
    return np.linalg.norm(estimated[:3, 3] - truth[:3, 3]) * 1000, np.degrees(angle)


def exact_poses(setup, flange_poses):
    """T_camera_board for flange poses (N, 4, 4), with the board fixed in the base (eye-in-hand) or on the flange."""
    fixed = transform([180, 0, 0], [0.4, -0.1, 0.02]) if setup == "eye-in-hand" else transform([175, 5, 0],
                                                                                              [-0.1, 0.07, 0.01])
    if setup == "eye-in-hand":
        return np.linalg.inv(T_FLANGE_CAMERA) @ np.linalg.inv(flange_poses) @ fixed
    return np.linalg.inv(T_BASE_CAMERA) @ flange_poses @ fixed


def varied_flange_poses(count, seed=0):
    rng = np.random.default_rng(seed)
    return np.array([transform(rng.uniform(-25, 25, 3) + [180, 0, 0], [0.4, -0.1, 0.45] + rng.uniform(-0.1, 0.1, 3))
                     for _ in range(count)])  # fmt: skip


@pytest.mark.parametrize("setup", ["eye-in-hand", "eye-to-hand"])
def test_every_method_recovers_an_exact_hand_eye_transform(setup):
    flange = varied_flange_poses(8)
    result = calibrate_hand_eye(flange, exact_poses(setup, flange), setup, CHESSBOARD.corners_m)
    truth = T_FLANGE_CAMERA if setup == "eye-in-hand" else T_BASE_CAMERA
    for entry in result.per_method:
        translation_mm, rotation_deg = hand_eye_error(entry.transform, truth)
        assert translation_mm < 1e-3 and rotation_deg < 1e-4, entry.method
        assert entry.scatter.corners_mm < 1e-3
    assert [entry.method for entry in result.per_method] == list(METHODS)


def test_the_board_scatter_measures_a_wrong_hand_eye_transform():
    flange = varied_flange_poses(8)
    board = exact_poses("eye-in-hand", flange)
    shifted = T_FLANGE_CAMERA.copy()
    shifted[:3, 3] += [0.002, 0.0, 0.0]
    exact = board_scatter(fixed_board_poses(flange, board, T_FLANGE_CAMERA, "eye-in-hand"), CHESSBOARD.corners_m)
    wrong = board_scatter(fixed_board_poses(flange, board, shifted, "eye-in-hand"), CHESSBOARD.corners_m)
    assert exact.translation_mm < 1e-6 and exact.rotation_deg < 1e-6
    # The 2 mm offset turns with the flange (+-25 deg): the board centre scatters by 2 mm x ~0.5 rad.
    assert 0.3 < wrong.translation_mm < 2.0 and wrong.rotation_deg < 1e-6


# Proof of issue 6 section 2: pixel noise, robot noise 0.1 mm and 0.05 deg (per axis), 10 captures.
@pytest.mark.parametrize("setup", ["eye-in-hand", "eye-to-hand"])
@pytest.mark.parametrize("name", sorted(BOARDS))
@pytest.mark.parametrize("seed", [0, 1])
def test_hand_eye_from_noisy_rendered_captures_is_within_1_mm_and_0_2_deg(setup, name, seed):
    board = BOARDS[name]
    captures = hand_eye_captures(board, setup, count=10, seed=seed)
    measured_noise_mm = np.linalg.norm(captures.flange_poses[:, :3, 3] - captures.true_flange_poses[:, :3, 3], axis=1)
    assert measured_noise_mm.mean() * 1000 > 0.1  # the robot noise is really there
    views = [detect_board(image, board) for image in captures.images]
    poses = np.array([estimate_board_pose(view, camera_matrix(D415), np.zeros(5)).T_camera_board for view in views])
    result = calibrate_hand_eye(captures.flange_poses, poses, setup, board.corners_m)
    translation_mm, rotation_deg = hand_eye_error(result.transform, captures.hand_eye)
    assert translation_mm < 1.0 and rotation_deg < 0.2, (result.method, translation_mm, rotation_deg)
    assert result.chosen.scatter.corners_mm == min(entry.scatter.corners_mm for entry in result.per_method)
    assert result.captures == 10


def test_a_named_method_is_used_even_if_another_scatters_less():
    flange = varied_flange_poses(8)
    board = exact_poses("eye-in-hand", flange)
    for method in METHODS:
        result = calibrate_hand_eye(flange, board, "eye-in-hand", CHESSBOARD.corners_m, method=method)
        assert result.method == method
        np.testing.assert_array_equal(result.transform, result.per_method[list(METHODS).index(method)].transform)


@pytest.mark.parametrize("count", [0, 1, 2, 3, 4, 5])
def test_fewer_than_6_captures_are_refused(count):
    """3 captures were accepted with a board scatter of 0.5 mm where the transform was 5 mm off."""
    flange = varied_flange_poses(count) if count else np.zeros((0, 4, 4))
    with pytest.raises(InputError, match=rf"needs at least 6 captures \(to check the answer by leaving each out\), "
                                         rf"got {count}; take 10-20"):  # fmt: skip
        calibrate_hand_eye(flange, exact_poses("eye-in-hand", flange), "eye-in-hand", CHESSBOARD.corners_m)


@pytest.mark.parametrize("setup", ["eye-in-hand", "eye-to-hand"])
def test_rotations_all_about_one_axis_are_refused(setup):
    # Only the wrist's last joint turns (flange z), 0 to 120 deg, while the arm moves the flange around.
    rng = np.random.default_rng(3)
    flange = np.array([transform([180, 0, 0], [0.4, -0.1, 0.45] + rng.uniform(-0.1, 0.1, 3))
                       @ transform([0, 0, angle], [0, 0, 0]) for angle in np.linspace(0, 120, 10)])  # fmt: skip
    with pytest.raises(InputError, match=r"all 10 captures turn the flange about one axis .*undetermined; tilt"):
        calibrate_hand_eye(flange, exact_poses(setup, flange), setup, CHESSBOARD.corners_m)
    # One capture tilted about another axis fixes the transform, but nothing could check it.
    flange[-1] = flange[-1] @ transform([20, 0, 0], [0, 0, 0])
    with pytest.raises(InputError, match=r"^without capture 10, the other 9 captures turn the flange about one axis "
                                         r".*, so the answer cannot be checked by leaving that capture out; tilt"):
        calibrate_hand_eye(flange, exact_poses(setup, flange), setup, CHESSBOARD.corners_m)
    # Two such captures check each other.
    flange[3] = flange[3] @ transform([0, -20, 0], [0, 0, 0])
    result = calibrate_hand_eye(flange, exact_poses(setup, flange), setup, CHESSBOARD.corners_m)
    truth = T_FLANGE_CAMERA if setup == "eye-in-hand" else T_BASE_CAMERA
    assert hand_eye_error(result.transform, truth)[0] < 1e-3


def test_rotations_too_similar_are_refused():
    rng = np.random.default_rng(4)
    flange = np.array([transform([180, 0, 0] + rng.uniform(-2, 2, 3), [0.4, -0.1, 0.45] + rng.uniform(-0.1, 0.1, 3))
                       for _ in range(10)])  # fmt: skip
    with pytest.raises(InputError, match=r"too similar in rotation: no two flange orientations differ by more than "
                                         r"\d\.\d deg \(at least 10 needed\); tilt the flange"):  # fmt: skip
        calibrate_hand_eye(flange, exact_poses("eye-in-hand", flange), "eye-in-hand", CHESSBOARD.corners_m)


def test_the_file_document_names_the_transform_by_setup_and_rounds_to_9_decimals():
    flange = varied_flange_poses(6)
    for setup, key in (("eye-in-hand", "T_flange_camera"), ("eye-to-hand", "T_base_camera")):
        document = calibrate_hand_eye(flange, exact_poses(setup, flange), setup, CHESSBOARD.corners_m).to_dict()
        assert list(document) == ["setup", key, "method", "captures", "residuals"]
        assert document["setup"] == setup and document["captures"] == 6
        matrix = np.array(document[key])
        assert matrix.shape == (4, 4) and matrix[3].tolist() == [0.0, 0.0, 0.0, 1.0]
        assert all(value == round(value, 9) for value in matrix.ravel())
        assert np.abs(matrix[:3, :3].T @ matrix[:3, :3] - np.eye(3)).max() < 1e-8
        residuals = document["residuals"]
        assert set(residuals["per_method"]) == set(METHODS)
        assert list(residuals) == ["leave_one_out", "board_scatter", "per_method"]
        chosen = residuals["per_method"][document["method"]]
        assert residuals["leave_one_out"] == chosen["leave_one_out"]
        assert residuals["board_scatter"] == chosen["board_scatter"]


def test_unknown_setup_or_method_is_refused():
    flange = varied_flange_poses(6)
    board = exact_poses("eye-in-hand", flange)
    with pytest.raises(InputError, match="setup 'eye-on-hand': expected one of eye-in-hand, eye-to-hand"):
        calibrate_hand_eye(flange, board, "eye-on-hand", CHESSBOARD.corners_m)
    with pytest.raises(InputError, match="method 'best': expected auto or one of tsai, park"):
        calibrate_hand_eye(flange, board, "eye-in-hand", CHESSBOARD.corners_m, method="best")


def test_a_failed_method_is_reported_as_null_and_never_chosen(monkeypatch):
    from weldseam.calibration import handeye

    solve = handeye.solve_hand_eye

    def park_fails(flange_poses, board_poses, setup, method):
        return np.full((4, 4), np.nan) if method == "park" else solve(flange_poses, board_poses, setup, method)

    monkeypatch.setattr(handeye, "solve_hand_eye", park_fails)
    flange = varied_flange_poses(6)
    board = exact_poses("eye-in-hand", flange)
    document = calibrate_hand_eye(flange, board, "eye-in-hand", CHESSBOARD.corners_m).to_dict()
    assert document["residuals"]["per_method"]["park"] == {
        "leave_one_out": {"translation_mm": None, "rotation_deg": None},
        "board_scatter": {"translation_mm": None, "rotation_deg": None, "corners_mm": None},
    }
    assert document["method"] != "park"
    with pytest.raises(InputError, match="the park method found no solution from these captures, or from them less "
                                         "one; try --method auto"):  # fmt: skip
        calibrate_hand_eye(flange, board, "eye-in-hand", CHESSBOARD.corners_m, method="park")
    monkeypatch.setattr(handeye, "solve_hand_eye", lambda *args: np.full((4, 4), np.nan))
    with pytest.raises(InputError, match="no hand-eye method found a solution from these 6 captures"):
        calibrate_hand_eye(flange, board, "eye-in-hand", CHESSBOARD.corners_m)


def detected_board_poses(captures):
    views = [detect_board(image, captures.board) for image in captures.images]
    return np.array([estimate_board_pose(view, camera_matrix(D415), np.zeros(5)).T_camera_board for view in views])


def test_the_leave_one_out_error_tracks_the_true_error():
    """Rendered captures with robot noise, 6, 8 and 12 of them, both setups, seeds 100-103 (not chosen): the
    true error is below 3x the estimate always and below 2x it in 9 of 10 cases, and the estimate ranks the
    runs as the true error does (0.73). The board scatter, the residual reported before, does not (-0.04).
    (Over 360 such runs, README: below 2x in 97 %, below 3x in all.)"""
    from scipy.stats import spearmanr

    runs = []
    for setup in ("eye-in-hand", "eye-to-hand"):
        for seed in range(100, 104):
            captures = hand_eye_captures(CHESSBOARD, setup, count=12, seed=seed)
            poses = detected_board_poses(captures)
            for count in (6, 8, 12):
                result = calibrate_hand_eye(captures.flange_poses[:count], poses[:count], setup, CHESSBOARD.corners_m)
                chosen = result.chosen
                runs.append((*hand_eye_error(result.transform, captures.hand_eye), chosen.error.translation_mm,
                             chosen.error.rotation_deg, chosen.scatter.translation_mm))  # fmt: skip
    true_mm, true_deg, estimated_mm, estimated_deg, scatter_mm = np.array(runs).T
    assert np.all(true_mm < 3 * estimated_mm) and np.all(true_deg < 3 * estimated_deg)
    assert np.mean(true_mm < 2 * estimated_mm) >= 0.9 and np.mean(true_deg < 2 * estimated_deg) >= 0.9
    assert spearmanr(estimated_mm, true_mm)[0] > 0.4
    assert spearmanr(scatter_mm, true_mm)[0] < 0.2


def test_the_leave_one_out_error_is_the_jackknife_of_the_transform():
    """Exact poses give an exact transform from every subset: zero; a wrong board pose in one capture moves
    the answer only when that capture is in, and the estimate is sqrt((N-1)/N) times the spread about the mean."""
    from weldseam.calibration.handeye import leave_one_out, solve_hand_eye

    flange = varied_flange_poses(8)
    board = exact_poses("eye-in-hand", flange)
    exact = leave_one_out(flange, board, "eye-in-hand", "park")
    assert exact.translation_mm < 1e-6 and exact.rotation_deg < 1e-6
    board[2] = board[2] @ transform([0.5, 0, 0], [0.003, 0, 0])
    solutions = np.array([solve_hand_eye(np.delete(flange, i, 0), np.delete(board, i, 0), "eye-in-hand", "park")
                          for i in range(8)])  # fmt: skip
    spread = np.sum((solutions[:, :3, 3] - solutions[:, :3, 3].mean(axis=0)) ** 2)
    error = leave_one_out(flange, board, "eye-in-hand", "park")
    assert error.translation_mm == pytest.approx(np.sqrt(7 / 8 * spread) * 1000, rel=1e-9)
    assert error.translation_mm > 0.1 and error.rotation_deg > 0.01


def test_a_failure_opencv_only_prints_is_a_failed_method_and_its_line_never_reaches_stderr(capfd):
    """With 3 captures OpenCV's Tsai prints "[ERROR] ... failed! Not enough informative motions" from C++ (past
    sys.stderr) and still returns a transform 100 mm off."""
    from weldseam.calibration.handeye import solve_hand_eye

    captures = hand_eye_captures(CHESSBOARD, "eye-in-hand", count=12, seed=0)
    poses = detected_board_poses(captures)
    assert np.isnan(solve_hand_eye(captures.flange_poses[:3], poses[:3], "eye-in-hand", "tsai")).all()
    assert np.isfinite(solve_hand_eye(captures.flange_poses[:3], poses[:3], "eye-in-hand", "park")).all()
    assert capfd.readouterr().err == ""
