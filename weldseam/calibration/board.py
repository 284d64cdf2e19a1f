"""Calibration boards (chessboard, ChArUco): geometry, detection in an image, pose in the camera frame.

Board frame, both kinds: origin at the top-left outer corner of the printed square grid, x along a row of
squares (to the right), y down a column, z into the board (away from a camera that sees its front). The
top-left square is black. Units: metres. A board pose `T_camera_board` (4, 4) maps board points to the
camera frame (OpenCV: x right, y down, z forward).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from weldseam.errors import InputError
from weldseam.types import Intrinsics

OPENCV_MISSING = "hand-eye calibration needs opencv: pip install 'weldseam[calibrate]'"
# Fewer corners than this give a PnP pose too weak to calibrate with (and 4 is PnP's bare minimum).
MIN_CHARUCO_CORNERS = 6


def require_opencv():
    """The cv2 module, or InputError saying how to install it."""
    try:
        import cv2
    except ImportError:
        raise InputError(OPENCV_MISSING) from None
    if not hasattr(cv2, "calibrateHandEye"):
        raise InputError(f"hand-eye calibration needs OpenCV 4.x (found {cv2.__version__}): "
                         "pip install 'weldseam[calibrate]'")  # fmt: skip
    return cv2


@dataclass(frozen=True)
class Chessboard:
    """A plain chessboard of (columns + 1) x (rows + 1) squares; columns x rows inner corners (OpenCV's size).

    One count even and the other odd: OpenCV then orders the corners from the black top-left square whichever
    way round the board is seen; a board with two even or two odd counts looks the same turned by 180 degrees.
    """

    columns: int
    rows: int
    square_m: float

    @property
    def corners_m(self) -> np.ndarray:
        """(columns * rows, 3) inner corners in the board frame, row by row: ((i + 1) s, (j + 1) s, 0)."""
        i, j = np.meshgrid(np.arange(self.columns), np.arange(self.rows))
        return np.column_stack([(i.ravel() + 1) * self.square_m, (j.ravel() + 1) * self.square_m, np.zeros(i.size)])

    @property
    def squares(self) -> tuple[int, int]:
        return self.columns + 1, self.rows + 1

    def describe(self) -> str:
        return f"chessboard {self.columns}x{self.rows} (inner corners)"


@dataclass(frozen=True)
class CharucoBoard:
    """A ChArUco board of squares_x x squares_y squares with ArUco markers in the white squares (OpenCV >= 4.6
    layout: the top-left square is black)."""

    squares_x: int
    squares_y: int
    square_m: float
    marker_m: float
    dictionary: str

    @property
    def corners_m(self) -> np.ndarray:
        """((squares_x - 1) * (squares_y - 1), 3) inner corners in the board frame, in ChArUco id order."""
        i, j = np.meshgrid(np.arange(self.squares_x - 1), np.arange(self.squares_y - 1))
        return np.column_stack([(i.ravel() + 1) * self.square_m, (j.ravel() + 1) * self.square_m, np.zeros(i.size)])

    @property
    def squares(self) -> tuple[int, int]:
        return self.squares_x, self.squares_y

    def describe(self) -> str:
        return f"ChArUco board {self.squares_x}x{self.squares_y} ({self.dictionary})"

    def opencv_board(self):
        """The cv2.aruco.CharucoBoard of this board."""
        cv2 = require_opencv()
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.squares_x, self.squares_y), self.square_m, self.marker_m, dictionary)


Board = Chessboard | CharucoBoard


def board_from_dict(data, source: str) -> Board:
    """A board from its manifest entry (lengths in mm), e.g. `{"type": "chessboard", "columns": 9, "rows": 6,
    "square_mm": 25}` or `{"type": "charuco", "squares_x": 7, "squares_y": 5, "square_mm": 30, "marker_mm": 22,
    "dictionary": "DICT_5X5_100"}`. `source` names the entry in error messages."""
    if not isinstance(data, dict) or data.get("type") not in ("chessboard", "charuco"):
        raise InputError(f'{source}: expected an object with "type": "chessboard" or "charuco"')
    integers = ("columns", "rows") if data["type"] == "chessboard" else ("squares_x", "squares_y")
    lengths = ("square_mm",) if data["type"] == "chessboard" else ("square_mm", "marker_mm")
    missing = [key for key in (*integers, *lengths) if key not in data]
    if missing:
        raise InputError(f"{source}: {data['type']} lacks {', '.join(missing)}")
    if not all(isinstance(data[key], int) and not isinstance(data[key], bool) and data[key] >= 3 for key in integers):
        raise InputError(f"{source}: {' and '.join(integers)} must be whole numbers >= 3")
    if not all(isinstance(data[key], (int, float)) and np.isfinite(data[key]) and data[key] > 0 for key in lengths):
        raise InputError(f"{source}: {' and '.join(lengths)} must be positive numbers (millimetres)")
    if data["type"] == "chessboard":
        if (data["columns"] + data["rows"]) % 2 == 0:
            raise InputError(
                f"{source}: a chessboard of {data['columns']}x{data['rows']} inner corners looks the same turned "
                "by 180 degrees; use one even and one odd count, e.g. 9x6"
            )
        return Chessboard(data["columns"], data["rows"], data["square_mm"] / 1000)
    dictionary = data.get("dictionary", "DICT_5X5_100")
    if not (isinstance(dictionary, str) and dictionary.startswith("DICT_") and hasattr(require_opencv().aruco,
                                                                                        dictionary)):
        raise InputError(f"{source}: unknown ArUco dictionary {dictionary!r} (e.g. DICT_5X5_100)")
    if data["marker_mm"] >= data["square_mm"]:
        raise InputError(f"{source}: marker_mm must be smaller than square_mm")
    return CharucoBoard(data["squares_x"], data["squares_y"], data["square_mm"] / 1000, data["marker_mm"] / 1000,
                        dictionary)  # fmt: skip


@dataclass(frozen=True)
class BoardView:
    """Board corners found in one image: pixels (K, 2) and the matching board points (K, 3) m."""

    corners_px: np.ndarray
    board_points_m: np.ndarray


@dataclass(frozen=True)
class BoardPose:
    """Board pose in the camera frame from one view; RMS reprojection error in pixels; corners used."""

    T_camera_board: np.ndarray
    reprojection_px: float
    corners: int


def camera_matrix(intrinsics: Intrinsics) -> np.ndarray:
    """(3, 3) pinhole matrix K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]."""
    return np.array([[intrinsics.fx, 0.0, intrinsics.cx], [0.0, intrinsics.fy, intrinsics.cy], [0.0, 0.0, 1.0]])


def detect_board(image: np.ndarray, board: Board) -> BoardView | None:
    """Find the board in a (H, W) uint8 grey image; None when it is not (fully, for a chessboard) visible."""
    if isinstance(board, Chessboard):
        return _detect_chessboard(image, board)
    return _detect_charuco(image, board)


def _detect_chessboard(image: np.ndarray, board: Chessboard) -> BoardView | None:
    cv2 = require_opencv()
    size = (board.columns, board.rows)
    found, corners = cv2.findChessboardCorners(image, size, flags=cv2.CALIB_CB_ADAPTIVE_THRESH
                                               | cv2.CALIB_CB_NORMALIZE_IMAGE)  # fmt: skip
    if not found:
        return None
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)
    corners = cv2.cornerSubPix(image, corners, (5, 5), (-1, -1), criteria).reshape(-1, 2).astype(np.float64)
    return BoardView(corners_px=corners, board_points_m=board.corners_m)


def _detect_charuco(image: np.ndarray, board: CharucoBoard) -> BoardView | None:
    cv2 = require_opencv()
    corners, ids, _, _ = cv2.aruco.CharucoDetector(board.opencv_board()).detectBoard(image)
    if ids is None or len(ids) < MIN_CHARUCO_CORNERS:
        return None
    points = board.corners_m[ids.ravel()]
    # Corners along one line leave the board's rotation about that line undetermined.
    if np.linalg.svd(points[:, :2] - points[:, :2].mean(axis=0), compute_uv=False)[1] < 0.5 * board.square_m:
        return None
    return BoardView(corners_px=corners.reshape(-1, 2).astype(np.float64), board_points_m=points)


def estimate_board_pose(view: BoardView, camera: np.ndarray, distortion: np.ndarray) -> BoardPose:
    """Board pose from its corners: planar PnP (IPPE), refined by Levenberg-Marquardt on the reprojection error
    sum |project(K, dist, R X + t) - x|^2. camera: (3, 3) K; distortion: OpenCV coefficients (k1, k2, p1, p2[, k3])."""
    cv2 = require_opencv()
    points, pixels = view.board_points_m, view.corners_px
    found, rvec, tvec = cv2.solvePnP(points, pixels, camera, distortion, flags=cv2.SOLVEPNP_IPPE)
    if not found:
        raise InputError("solvePnP found no board pose")
    rvec, tvec = cv2.solvePnPRefineLM(points, pixels, camera, distortion, rvec, tvec)
    projected, _ = cv2.projectPoints(points, rvec, tvec, camera, distortion)
    reprojection_px = float(np.sqrt(np.mean(np.sum((projected.reshape(-1, 2) - pixels) ** 2, axis=1))))
    transform = np.eye(4)
    transform[:3, :3] = cv2.Rodrigues(rvec)[0]
    transform[:3, 3] = tvec.ravel()
    return BoardPose(T_camera_board=transform, reprojection_px=reprojection_px, corners=len(points))
