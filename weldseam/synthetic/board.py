"""Synthetic hand-eye captures: a calibration board rendered by a pinhole camera, with the robot flange poses
that go with each image for a known hand-eye transform, robot pose noise and image noise. Deterministic from
a seed. Units: metres and radians; frames as in weldseam.calibration.board.

Write a capture set to try `weldseam calibrate hand-eye` on:

    python -m weldseam.synthetic.board calib [eye-in-hand|eye-to-hand] [chessboard|charuco]
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from weldseam.calibration.board import Board, CharucoBoard, Chessboard, camera_matrix, require_opencv
from weldseam.io.depth import write_intrinsics
from weldseam.robot.kinematics import ROBOTS, inverse
from weldseam.synthetic.sensor import D415, look_at
from weldseam.types import Intrinsics

CHESSBOARD = Chessboard(columns=9, rows=6, square_m=0.02)
CHARUCO = CharucoBoard(squares_x=7, squares_y=5, square_m=0.03, marker_m=0.022, dictionary="DICT_5X5_100")
# Paper around the printed squares (a quiet zone the detectors need), in squares; grey table around the paper.
PAPER_MARGIN_SQUARES = 0.75
BACKGROUND_GREY = 90
# Eye-in-hand truth: the camera 60 mm off the flange axis, 45 mm out, looking roughly along the flange z axis.
T_FLANGE_CAMERA = np.eye(4)
T_FLANGE_CAMERA[:3, :3] = Rotation.from_euler("xyz", [4.0, -6.0, 91.0], degrees=True).as_matrix()
T_FLANGE_CAMERA[:3, 3] = [0.035, -0.06, 0.045]
# Eye-to-hand truth: a camera 1 m above the table looking down at the work area.
T_BASE_CAMERA = look_at([0.55, 0.25, 1.0], [0.45, 0.0, 0.35], up=(1.0, 0.0, 0.0))
# The board lies face up on the table (eye-in-hand): board z (into the board) points down.
T_BASE_BOARD = np.eye(4)
T_BASE_BOARD[:3, :3] = Rotation.from_euler("xz", [180.0, 15.0], degrees=True).as_matrix()
T_BASE_BOARD[:3, 3] = [0.30, -0.10, 0.0]


def board_texture(board: Board, pixels_per_square: int) -> tuple[np.ndarray, np.ndarray]:
    """The printed board as a uint8 image and the (3, 3) map from its pixel coordinates to board-plane metres.

    A texture pixel (u, v) (centre at integer coordinates) is the board point ((u + 0.5 - m) s / p,
    (v + 0.5 - m) s / p) with m the paper margin in pixels, s the square size and p the pixels per square.
    """
    columns, rows = board.squares
    margin = int(round(PAPER_MARGIN_SQUARES * pixels_per_square))
    size = (columns * pixels_per_square + 2 * margin, rows * pixels_per_square + 2 * margin)
    if isinstance(board, Chessboard):
        v, u = np.mgrid[0 : size[1], 0 : size[0]]
        i, j = (u - margin) // pixels_per_square, (v - margin) // pixels_per_square
        inside = (i >= 0) & (i < columns) & (j >= 0) & (j < rows)
        texture = np.where(inside & ((i + j) % 2 == 0), 0, 255).astype(np.uint8)
    else:
        texture = board.opencv_board().generateImage(size, marginSize=margin, borderBits=1)
    scale = board.square_m / pixels_per_square
    to_board = np.array([[scale, 0.0, (0.5 - margin) * scale], [0.0, scale, (0.5 - margin) * scale], [0, 0, 1.0]])
    return texture, to_board


def render_board(board: Board, intrinsics: Intrinsics, T_camera_board: np.ndarray, rng: np.random.Generator, *,
                 noise_grey: float = 2.0, supersample: int = 3) -> np.ndarray:  # fmt: skip
    """(H, W) uint8 grey image of the board seen at T_camera_board: plane homography H = K [r1 r2 t] applied to
    the printed texture at `supersample` times the resolution, area-averaged down, slightly blurred, plus
    Gaussian grey-level noise (sigma `noise_grey`)."""
    cv2 = require_opencv()
    texture, to_board = board_texture(board, pixels_per_square=64)
    camera = camera_matrix(intrinsics)
    # Pixel centres at integer coordinates at both resolutions: u_fine = f (u + 0.5) - 0.5.
    fine = np.array([[supersample, 0.0, (supersample - 1) / 2], [0.0, supersample, (supersample - 1) / 2], [0, 0, 1]])
    plane = np.column_stack([T_camera_board[:3, 0], T_camera_board[:3, 1], T_camera_board[:3, 3]])
    homography = fine @ camera @ plane @ to_board
    size = (intrinsics.width * supersample, intrinsics.height * supersample)
    image = cv2.warpPerspective(texture, homography, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                                borderValue=BACKGROUND_GREY).astype(np.float32)  # fmt: skip
    image = cv2.resize(image, (intrinsics.width, intrinsics.height), interpolation=cv2.INTER_AREA)
    image = cv2.GaussianBlur(image, (0, 0), 0.6)
    image = image + rng.normal(0.0, noise_grey, image.shape)
    return np.clip(np.round(image), 0, 255).astype(np.uint8)


def board_views(board: Board, intrinsics: Intrinsics, count: int, rng: np.random.Generator, *,
                distance_m: tuple[float, float] = (0.42, 0.6), tilt_deg: tuple[float, float] = (15.0, 40.0),
                margin_px: float = 15.0, accept: Callable[[np.ndarray], bool] | None = None) -> np.ndarray:  # fmt: skip
    """(count, 4, 4) T_camera_board of varied views that keep the whole paper inside the image (and that
    `accept`, given T_camera_board, agrees to).

    The camera sits at distance d from a point near the board centre, tilted by t from the board normal at an
    azimuth that goes round the board, looking at that point, turned by a random roll about its optical axis.
    """
    columns, rows = board.squares
    centre = np.array([columns, rows, 0.0]) * board.square_m / 2
    half = (np.array([columns, rows]) / 2 + PAPER_MARGIN_SQUARES) * board.square_m
    paper = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half + centre[:2]
    paper = np.column_stack([paper, np.zeros(4)])
    camera = camera_matrix(intrinsics)
    views = []
    while len(views) < count:
        azimuth = 2 * np.pi * (len(views) + rng.uniform(-0.3, 0.3)) / count
        tilt = np.radians(rng.uniform(*tilt_deg))
        target = centre + np.append(rng.uniform(-0.02, 0.02, 2), 0.0)
        direction = np.array([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), -np.cos(tilt)])
        eye = target + rng.uniform(*distance_m) * direction
        z = (target - eye) / np.linalg.norm(target - eye)
        x = np.array([1.0, 0.0, 0.0]) - z[0] * z
        x = Rotation.from_rotvec(rng.uniform(-np.pi, np.pi) * z).apply(x / np.linalg.norm(x))
        T_board_camera = np.eye(4)
        T_board_camera[:3, :3] = np.column_stack([x, np.cross(z, x), z])
        T_board_camera[:3, 3] = eye
        T_camera_board = np.linalg.inv(T_board_camera)
        seen = paper @ T_camera_board[:3, :3].T + T_camera_board[:3, 3]
        pixels = seen @ camera.T
        pixels = pixels[:, :2] / pixels[:, 2:]
        low, high = margin_px, np.array([intrinsics.width, intrinsics.height]) - 1 - margin_px
        if np.all((pixels >= low) & (pixels <= high)) and (accept is None or accept(T_camera_board)):
            views.append(T_camera_board)
    return np.array(views)


def perturb_poses(poses: np.ndarray, rng: np.random.Generator, translation_m: float, rotation_rad: float) -> np.ndarray:
    """(N, 4, 4) poses moved by a small random motion: N(0, translation_m) per axis, rotation vector N(0,
    rotation_rad) per axis, applied in the pose's own frame (as a robot's repeatability error)."""
    noise = np.tile(np.eye(4), (len(poses), 1, 1))
    noise[:, :3, :3] = Rotation.from_rotvec(rng.normal(0.0, rotation_rad, (len(poses), 3))).as_matrix()
    noise[:, :3, 3] = rng.normal(0.0, translation_m, (len(poses), 3))
    return poses @ noise


@dataclass(frozen=True)
class HandEyeCaptures:
    """Synthetic captures: images (N, H, W) uint8; measured (noisy) and true flange poses (N, 4, 4) in the base
    frame; the true hand-eye transform (T_flange_camera or T_base_camera, per setup)."""

    setup: str
    board: Board
    intrinsics: Intrinsics
    images: np.ndarray
    flange_poses: np.ndarray
    true_flange_poses: np.ndarray
    hand_eye: np.ndarray


def hand_eye_captures(
    board: Board,
    setup: str,
    *,
    count: int = 10,
    seed: int = 0,
    intrinsics: Intrinsics = D415,
    translation_noise_m: float = 1e-4,
    rotation_noise_rad: float = np.radians(0.05),
    noise_grey: float = 2.0,
) -> HandEyeCaptures:
    """Captures of a board for a known hand-eye transform (eye-in-hand: board on the table, camera on the
    flange at T_FLANGE_CAMERA; eye-to-hand: camera at T_BASE_CAMERA, board on the flange, facing out).

    Eye-in-hand: T_base_flange = T_base_board inv(T_camera_board) inv(X); eye-to-hand: T_base_flange =
    Z T_camera_board inv(T_flange_board); every one within a UR5's reach. The flange poses returned are the
    true ones with robot noise.
    """
    if setup == "eye-in-hand":
        hand_eye = T_FLANGE_CAMERA
        # Closer views of a board on the table keep more of them within reach.
        distance_m = (0.38, 0.5)

        def flange_pose(T_camera_board):
            return T_BASE_BOARD @ np.linalg.inv(T_camera_board) @ np.linalg.inv(hand_eye)
    else:
        hand_eye = T_BASE_CAMERA
        distance_m = (0.42, 0.6)
        columns, rows = board.squares
        T_flange_board = np.eye(4)
        T_flange_board[:3, :3] = Rotation.from_euler("x", 180.0, degrees=True).as_matrix()
        T_flange_board[:3, 3] = T_flange_board[:3, :3] @ -np.array([columns, rows, 0.0]) * board.square_m / 2
        T_flange_board[2, 3] = 0.01

        def flange_pose(T_camera_board):
            return hand_eye @ T_camera_board @ np.linalg.inv(T_flange_board)

    rng = np.random.default_rng(seed)
    views = board_views(board, intrinsics, count, rng, distance_m=distance_m,
                        accept=lambda view: len(inverse(ROBOTS["ur5"], flange_pose(view))) > 0)  # fmt: skip
    true_flange = np.array([flange_pose(view) for view in views])
    images = np.array([render_board(board, intrinsics, view, rng, noise_grey=noise_grey) for view in views])
    measured = perturb_poses(true_flange, rng, translation_noise_m, rotation_noise_rad)
    return HandEyeCaptures(setup=setup, board=board, intrinsics=intrinsics, images=images, flange_poses=measured,
                           true_flange_poses=true_flange, hand_eye=hand_eye)  # fmt: skip


def board_manifest_entry(board: Board) -> dict:
    """The manifest's "board" object for a board (lengths in mm)."""
    if isinstance(board, Chessboard):
        return {"type": "chessboard", "columns": board.columns, "rows": board.rows,
                "square_mm": round(board.square_m * 1000, 6)}  # fmt: skip
    return {"type": "charuco", "squares_x": board.squares_x, "squares_y": board.squares_y,
            "square_mm": round(board.square_m * 1000, 6), "marker_mm": round(board.marker_m * 1000, 6),
            "dictionary": board.dictionary}  # fmt: skip


def write_capture_set(directory: str | Path, captures: HandEyeCaptures, *, joints: bool = False) -> Path:
    """Write the images (capNN.png), intrinsics.json, manifest.json and truth.json (the true hand-eye transform,
    in the hand-eye file's format) into `directory`; return the manifest path. Each capture gives its flange
    pose as a UR pose vector, or, with `joints`, as UR5 joint angles (one inverse kinematics solution of the
    measured flange pose)."""
    cv2 = require_opencv()
    from weldseam.robot.motion import pose_vectors

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    write_intrinsics(directory / "intrinsics.json", captures.intrinsics)
    entries = []
    for index, (image, pose) in enumerate(zip(captures.images, captures.flange_poses), start=1):
        name = f"cap{index:02d}.png"
        cv2.imwrite(str(directory / name), image)
        if joints:
            solutions = inverse(ROBOTS["ur5"], pose)
            if len(solutions) == 0:
                raise ValueError(f"capture {index}: the UR5 cannot reach this flange pose")
            entries.append({"image": name, "joints_rad": [round(float(q), 12) for q in solutions[0]]})
        else:
            entries.append({"image": name, "flange_pose": [round(float(x), 12) for x in pose_vectors(pose)]})
    key = "T_flange_camera" if captures.setup == "eye-in-hand" else "T_base_camera"
    truth = {"setup": captures.setup, key: np.round(captures.hand_eye, 9).tolist()}
    (directory / "truth.json").write_text(json.dumps(truth, indent=2) + "\n")
    manifest = {"setup": captures.setup, "intrinsics": "intrinsics.json",
                "board": board_manifest_entry(captures.board), "captures": entries}  # fmt: skip
    path = directory / "manifest.json"
    path.write_text(json.dumps(manifest, indent=2) + "\n")
    return path


def main(argv: list[str]) -> None:
    """`python -m weldseam.synthetic.board DIR [SETUP] [BOARD]`: write a synthetic capture set into DIR."""
    if not argv or len(argv) > 3:
        sys.exit(__doc__)
    setup = argv[1] if len(argv) > 1 else "eye-in-hand"
    kind = argv[2] if len(argv) > 2 else "chessboard"
    if setup not in ("eye-in-hand", "eye-to-hand") or kind not in ("chessboard", "charuco"):
        sys.exit(__doc__)
    board = CHESSBOARD if kind == "chessboard" else CHARUCO
    print(write_capture_set(argv[0], hand_eye_captures(board, setup, count=12)))


if __name__ == "__main__":
    main(sys.argv[1:])
