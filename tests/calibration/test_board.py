"""Board geometry, detection and pose against rendered images whose board pose is known."""

import subprocess
import sys
import types

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from weldseam.calibration.board import (
    OPENCV_MISSING,
    CharucoBoard,
    Chessboard,
    board_from_dict,
    camera_matrix,
    detect_board,
    estimate_board_pose,
    require_opencv,
)
from weldseam.errors import InputError
from weldseam.synthetic.board import CHARUCO, CHESSBOARD, board_views, render_board
from weldseam.synthetic.sensor import D415

BOARDS = {"chessboard": CHESSBOARD, "charuco": CHARUCO}


def pose_error(estimated, truth, board):
    """Board-centre distance (mm) and rotation angle (deg) between two T_camera_board."""
    centre = np.array([*board.squares, 0.0]) * board.square_m / 2
    moved = [pose[:3, :3] @ centre + pose[:3, 3] for pose in (estimated, truth)]
    angle = Rotation.from_matrix(estimated[:3, :3].T @ truth[:3, :3]).magnitude()
    return np.linalg.norm(moved[0] - moved[1]) * 1000, np.degrees(angle)


@pytest.mark.parametrize("name", sorted(BOARDS))
def test_the_pose_of_a_rendered_board_is_recovered_whatever_its_roll(name):
    board = BOARDS[name]
    rng = np.random.default_rng(7)
    views = board_views(board, D415, 8, rng)
    rolls = Rotation.from_matrix(views[:, :3, :3]).as_euler("zyx", degrees=True)[:, 0]
    assert np.ptp(rolls) > 180  # views turned every way round: a corner-order mix-up would show
    for view in views:
        found = detect_board(render_board(board, D415, view, rng), board)
        pose = estimate_board_pose(found, camera_matrix(D415), np.zeros(5))
        centre_mm, angle_deg = pose_error(pose.T_camera_board, view, board)
        assert centre_mm < 0.6 and angle_deg < 0.1
        assert pose.reprojection_px < 0.3 and pose.corners == len(board.corners_m)


def test_corner_coordinates_follow_the_board_frame():
    corners = Chessboard(columns=9, rows=6, square_m=0.025).corners_m
    assert corners.shape == (54, 3)
    np.testing.assert_allclose(corners[[0, 1, 9, 53]], [[0.025, 0.025, 0], [0.05, 0.025, 0], [0.025, 0.05, 0],
                                                        [0.225, 0.15, 0]])  # fmt: skip
    # Our ChArUco frame is OpenCV's: corner ids index the same points.
    np.testing.assert_allclose(CHARUCO.corners_m, CHARUCO.opencv_board().getChessboardCorners(), atol=1e-7)


@pytest.mark.parametrize("name", sorted(BOARDS))
def test_no_board_in_the_image_is_none(name):
    blank = np.full((D415.height, D415.width), 128, dtype=np.uint8)
    assert detect_board(blank, BOARDS[name]) is None


def test_a_chessboard_partly_out_of_view_is_not_found():
    view = board_views(CHESSBOARD, D415, 1, np.random.default_rng(0))[0]
    image = render_board(CHESSBOARD, D415, view, np.random.default_rng(0))
    corners = detect_board(image, CHESSBOARD).corners_px
    image[:, : int(corners[:, 0].mean())] = 90  # the left half of the board hidden
    assert detect_board(image, CHESSBOARD) is None


def test_board_entries_are_read_in_millimetres():
    assert board_from_dict({"type": "chessboard", "columns": 9, "rows": 6, "square_mm": 25}, "m") == Chessboard(
        9, 6, 0.025
    )
    charuco = {"type": "charuco", "squares_x": 7, "squares_y": 5, "square_mm": 30, "marker_mm": 22}
    assert board_from_dict(charuco, "m") == CharucoBoard(7, 5, 0.03, 0.022, "DICT_5X5_100")


@pytest.mark.parametrize(
    "entry, message",
    [
        ({"type": "circles"}, 'm: expected an object with "type": "chessboard" or "charuco"'),
        ({"type": "chessboard", "columns": 9, "rows": 6}, "m: chessboard lacks square_mm"),
        ({"type": "chessboard", "columns": 9, "rows": 7, "square_mm": 25}, "looks the same turned by 180 degrees"),
        ({"type": "chessboard", "columns": 9, "rows": 2, "square_mm": 25}, "columns and rows must be whole numbers"),
        ({"type": "chessboard", "columns": 9, "rows": 6, "square_mm": -1}, "square_mm must be positive"),
        ({"type": "charuco", "squares_x": 7, "squares_y": 5, "square_mm": 30, "marker_mm": 30}, "marker_mm must be"),
        ({"type": "charuco", "squares_x": 7, "squares_y": 5, "square_mm": 30, "marker_mm": 22, "dictionary": "X"},
         "unknown ArUco dictionary 'X'"),
    ],
)
def test_bad_board_entries_are_refused_with_the_reason(entry, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        board_from_dict(entry, "m")


def test_missing_opencv_is_one_clear_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "cv2", None)
    with pytest.raises(InputError) as error:
        require_opencv()
    assert str(error.value) == OPENCV_MISSING == "hand-eye calibration needs opencv: pip install 'weldseam[calibrate]'"


def test_opencv_without_the_hand_eye_solvers_is_one_clear_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "cv2", types.SimpleNamespace(__version__="5.0.0"))
    with pytest.raises(InputError, match=r"needs OpenCV 4.x \(found 5.0.0\)"):
        require_opencv()


def test_opencv_is_not_imported_with_weldseam():
    code = (
        "import sys, weldseam.calibration.board, weldseam.calibration.handeye, weldseam.commands.calibrate; "
        "print('cv2' in sys.modules)"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert loaded.stdout.strip() == "False", loaded.stderr
