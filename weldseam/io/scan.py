"""Load a scan from any supported input into the base frame, with its camera origin."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from weldseam.errors import InputError
from weldseam.geometry import column_bounds, finite_rows, transform_points
from weldseam.io.clouds import read_cloud
from weldseam.io.depth import backproject_depth, read_depth_png
from weldseam.io.files import read_json
from weldseam.io.poses import POSE_KEYS, FramePose, pose_from_json, read_pose_file
from weldseam.types import FRAMES, Intrinsics, Scan

UNIT_SCALE = {"m": 1.0, "mm": 0.001}
LARGEST_PLAUSIBLE_EXTENT_M = 10.0
SMALLEST_PLAUSIBLE_EXTENT_M = 0.01
# Depth cameras see from a few centimetres to a few metres; a median depth outside this range
# means the depth scale is off, most often by 1000 (millimetres taken as metres or back).
PLAUSIBLE_DEPTH_M = (0.05, 10.0)
# A camera sees what lies in front of it, within its field of view (at most ~45 degrees off its
# axis for depth cameras; 70 leaves room for pose error). Fewer points than this share inside
# that cone: the cloud is not where the pose says the camera saw it.
VIEW_CONE_DEG = 70.0
MIN_IN_VIEW = 0.5
FRAME_KEYS = ("scan", "intrinsics", "pose")  # a manifest frame's keys besides an inline pose


def load_scan(
    source: str,
    *,
    intrinsics: Intrinsics | None = None,
    intrinsics_source: str = "the intrinsics",
    T_base_camera: np.ndarray | None = None,
    cloud_frame: str = "base",
    camera_origin_m: np.ndarray | None = None,
    units: str = "m",
    stdin=None,
) -> tuple[Scan, list[str]]:
    """Read `source` (cloud file, `-` for a PLY on stdin, or a 16-bit depth PNG with its
    `intrinsics`, read from `intrinsics_source`, named in messages) and return it with any
    notes for the user.

    A depth image, and a cloud with `cloud_frame="camera"`, are in the camera frame and are
    mapped to the base frame by `T_base_camera` (4, 4); without it they stay in the camera
    frame (Scan.frame "camera", said in a note). The camera origin (to orient normals) is
    `camera_origin_m` if given, else the pose's translation, else the camera frame's origin
    for camera-frame data, else unknown.
    """
    notes: list[str] = []
    if units not in UNIT_SCALE:
        raise InputError(f"--units must be m or mm, got {units!r}")
    if cloud_frame not in FRAMES:
        raise InputError(f"--cloud-frame must be base or camera, got {cloud_frame!r}")
    pose = T_base_camera
    is_depth = source != "-" and Path(source).suffix.lower() == ".png"
    if is_depth:
        if intrinsics is None:
            raise InputError(f"{source}: a depth image needs --intrinsics FILE.json")
        depth = read_depth_png(source)
        if depth.shape != (intrinsics.height, intrinsics.width):
            raise InputError(
                f"{source}: image is {depth.shape[1]}x{depth.shape[0]} but {intrinsics_source} says "
                f"{intrinsics.width}x{intrinsics.height}"
            )
        points = backproject_depth(depth, intrinsics)
        if len(points) == 0:
            raise InputError(f"{source}: the depth image has no valid (non-zero) pixels")
        _check_depth_scale(source, points, intrinsics.depth_scale, intrinsics_source)
        sha256 = hashlib.sha256(Path(source).read_bytes()).hexdigest()
        in_camera_frame = True
    else:
        if intrinsics is not None:
            raise InputError(f"{source}: --intrinsics applies to depth images (.png) only")
        points, sha256 = read_cloud(source, stdin=stdin)
        points = points * UNIT_SCALE[units]
        _check_units(source, points, units)
        in_camera_frame = cloud_frame == "camera"
    if in_camera_frame and pose is not None:
        points = transform_points(pose, points)
    elif pose is not None:
        _check_in_view(source, points, pose)
    if camera_origin_m is not None:
        origin = np.asarray(camera_origin_m, dtype=np.float64)
    elif pose is not None:
        origin = pose[:3, 3].copy()
    elif in_camera_frame:
        origin = np.zeros(3)
    else:
        origin = None
    frame = "camera" if in_camera_frame and pose is None else "base"
    if frame == "camera":
        notes.append(f"{source}: no camera pose: the scan and the path are in the camera frame, not the robot base")
    scan = Scan(points_m=points, camera_origin_m=origin, source=source, sha256=sha256, frame=frame)
    return scan, notes


@dataclass(frozen=True, eq=False)
class FrameSpec:
    """One frame of a multi-frame plan: the scan, its intrinsics (depth images) and its pose."""

    scan: str
    intrinsics: str | None = None
    pose: FramePose | None = None


def read_frames_manifest(path: str | Path) -> tuple[list[FrameSpec], str | None]:
    """Frames and hand-eye file of a manifest; relative paths are relative to its folder.

    `{"hand_eye": "H.json", "frames": [{"scan": "f1.png", "intrinsics": "d415.json",
    "joints_rad": [...]}, {"scan": "f2.png", "pose": "f2.pose.json"}, ...]}`: each frame has
    a scan, intrinsics for a depth image, and its pose either inline (the keys of a pose
    file) or as a pose file under "pose". "hand_eye" is optional.
    """
    data = read_json(path, "a frames manifest")
    folder = Path(path).parent
    if not isinstance(data, dict) or not isinstance(data.get("frames"), list) or not data["frames"]:
        raise InputError(f'{path}: expected a JSON object with a non-empty "frames" list')

    def relative(value, key: str) -> str:
        if not isinstance(value, str) or not value:
            raise InputError(f"{path}: {key} must be a file name, got {value!r}")
        return str(folder / value)

    hand_eye = relative(data["hand_eye"], "hand_eye") if data.get("hand_eye") is not None else None
    frames = []
    for index, frame in enumerate(data["frames"]):
        where = f"frames[{index}]"
        if not isinstance(frame, dict) or "scan" not in frame:
            raise InputError(f'{path}: {where} must be an object with "scan" and a pose')
        intrinsics = relative(frame["intrinsics"], f"{where}.intrinsics") if "intrinsics" in frame else None
        inline = [key for key in POSE_KEYS if key in frame]
        if "pose" in frame and inline:
            raise InputError(f'{path}: {where} has both "pose" and {inline[0]}: give one')
        if "pose" in frame or not inline:
            unknown = sorted(set(frame) - set(FRAME_KEYS))
            if unknown:
                allowed = ", ".join(f'"{key}"' for key in FRAME_KEYS)
                raise InputError(f'{path}: {where}: unknown key "{unknown[0]}" (allowed: {allowed}, or a pose inline)')
        if "pose" in frame:
            pose = read_pose_file(relative(frame["pose"], f"{where}.pose"))
        else:
            pose = pose_from_json(frame, f"{path}: {where}", other_keys=FRAME_KEYS) if inline else None
        frames.append(FrameSpec(relative(frame["scan"], f"{where}.scan"), intrinsics, pose))
    return frames, hand_eye


def _check_units(source: str, points: np.ndarray, units: str) -> None:
    finite = points.take(np.flatnonzero(finite_rows(points)), axis=0)
    if len(finite) < 2:
        return
    low, high = column_bounds(finite)
    extent = float(np.linalg.norm(high - low))
    if extent > LARGEST_PLAUSIBLE_EXTENT_M:
        hint = "it looks like millimetres: pass --units mm" if units == "m" else "check the file's units"
        raise InputError(f"{source}: the cloud spans {extent:.4g} m, too large for a workpiece scan; {hint}")
    if extent < SMALLEST_PLAUSIBLE_EXTENT_M:
        hint = "it looks like metres: drop --units mm" if units == "mm" else "check the file's units"
        raise InputError(
            f"{source}: the cloud spans only {extent * 1000:.4g} mm, too small for a workpiece scan; {hint}"
        )


def _check_depth_scale(source: str, points: np.ndarray, depth_scale: float, intrinsics: str) -> None:
    """InputError naming the depth_scale to pass when the median depth is implausible."""
    median = float(np.median(points[:, 2]))
    low, high = PLAUSIBLE_DEPTH_M
    if low <= median <= high:
        return
    factor = 1000.0 ** round(np.log10(median / 0.5) / 3)
    raise InputError(
        f"{source}: the median depth is {median:.4g} m with depth_scale {depth_scale:g} (units per metre, "
        f"{intrinsics}), not a depth camera's {low:g}-{high:g} m: depth_scale {depth_scale * factor:g} gives "
        f"{median / factor:.3g} m"
    )


def _check_in_view(source: str, points: np.ndarray, T_base_camera: np.ndarray) -> None:
    """InputError for a cloud given as base frame that looks like the camera's own (see
    `_camera_like`) while most of it lies outside the view of the camera at T_base_camera (4, 4):
    a camera-frame cloud without --cloud-frame camera. A pose that only gives a base-frame
    cloud its camera origin is not questioned."""
    finite = points.take(np.flatnonzero(finite_rows(points)), axis=0)
    if not _camera_like(finite):
        return
    in_camera = transform_points(np.linalg.inv(T_base_camera), finite)
    share = float(np.mean(_in_view(in_camera)))
    if share < MIN_IN_VIEW:
        raise InputError(
            f"{source}: only {share:.0%} of the points lie in front of the camera its pose places "
            f"(within {VIEW_CONE_DEG:g} degrees of its axis): if the cloud is in the camera frame, pass "
            "--cloud-frame camera; else check the pose"
        )


def _in_view(points: np.ndarray) -> np.ndarray:
    """(N,) bool: camera-frame points (N, 3) within VIEW_CONE_DEG of the +z axis, at a depth
    camera's distance (PLAUSIBLE_DEPTH_M)."""
    off_axis = np.degrees(np.arctan2(np.hypot(points[:, 0], points[:, 1]), points[:, 2]))
    low, high = PLAUSIBLE_DEPTH_M
    return (points[:, 2] > low) & (points[:, 2] < high) & (off_axis < VIEW_CONE_DEG)


def _camera_like(points: np.ndarray) -> bool:
    """Whether finite points (N, 3) lie as a camera's own cloud does: nearly all in view of a
    camera at the origin looking along +z (a part on a table in the base frame lies around z = 0)."""
    return bool(np.mean(_in_view(points)) >= 0.99)


def camera_frame_hint(scan: Scan) -> str | None:
    """For a cloud taken as base frame with no pose: a hint when it looks like camera-frame
    data (`_camera_like`), else None."""
    finite = scan.points_m.take(np.flatnonzero(finite_rows(scan.points_m)), axis=0)
    if not _camera_like(finite):
        return None
    depth = finite[:, 2]
    return (
        f"{scan.source} looks like a camera-frame cloud (every point {depth.min():.2f}-{depth.max():.2f} m in front "
        "of the origin, within a camera's view): if it is, pass --cloud-frame camera with --camera-pose"
    )
