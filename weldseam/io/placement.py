"""Where the scans of a run sit: the placement options of `plan` and `report` resolved into
scans in the base frame, with a record of every input that placed them.

For each input the first source that has it wins:
- a depth image's intrinsics: --intrinsics (or the manifest's), the run record, the
  intrinsics file beside the scan (`weldseam.io.sidecars`);
- the camera pose: --camera-pose, --flange-pose or --joints (or the manifest's), the run
  record (unless --hand-eye or --robot is given), the pose file beside the scan (with
  --hand-eye for a robot state), none (the camera frame);
- the cloud frame, units and camera origin: the option, the run record, base / m / none.
The run record is the `input.placement` of a path JSON given as --config (or the path JSON a
report is drawn for); it applies to a scan only when the scan's sha256 is the recorded one.
"""

from __future__ import annotations

import hashlib
import io
import sys
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from weldseam.errors import InputError
from weldseam.io.depth import intrinsics_from_json, read_intrinsics
from weldseam.io.files import read_input, read_json
from weldseam.io.hand_eye import camera_pose, joints_robot, read_hand_eye
from weldseam.io.poses import FramePose, parse_vector, pose_vector_matrix, read_pose_file, rigid_transform
from weldseam.io.scan import UNIT_SCALE, camera_frame_hint, load_scan, read_frames_manifest
from weldseam.io.sidecars import own_pose_name, sidecars
from weldseam.types import FRAMES, Intrinsics, RunResult, Scan


@dataclass(frozen=True)
class PlacementOptions:
    """The placement options as given on the command line; None: not given."""

    scans: tuple[str, ...] = ()
    frames: str | None = None
    intrinsics: str | None = None
    camera_pose: str | None = None
    flange_pose: str | None = None
    joints: str | None = None
    hand_eye: str | None = None
    robot: str | None = None
    cloud_frame: str | None = None
    camera_origin: str | None = None
    units: str | None = None


@dataclass(frozen=True)
class FramePlacement:
    """How one scan was placed, as recorded. T_base_camera (4, 4) or None (camera frame);
    camera_origin_m (3,) or None (from the pose); intrinsics of a depth image or None."""

    cloud_frame: str = "base"
    units: str = "m"
    intrinsics: Intrinsics | None = None
    T_base_camera: np.ndarray | None = None
    camera_origin_m: np.ndarray | None = None


@dataclass(frozen=True)
class Recorded:
    """The placements a path JSON recorded, by the sha256 of each scan; source: the file."""

    source: str
    by_sha256: dict[str, FramePlacement]


@dataclass(frozen=True)
class Placed:
    """The scans of one run, placed.

    frames: each scan (a single scan is one frame); source: the name of the whole (the
    scan, the scans joined by commas, or the manifest); messages: where each input came
    from (stderr); warnings: what the user must know (stderr and the record's warnings);
    placements: one record per frame (`placement_record`).
    """

    frames: tuple[Scan, ...]
    source: str
    messages: tuple[str, ...]
    warnings: tuple[str, ...]
    placements: tuple[dict, ...]
    hints: tuple[str, ...] = ()

    @property
    def frame(self) -> str:
        """The frame the scans (and so the path) are in: "camera" if any lacks a pose."""
        return "camera" if any(scan.frame == "camera" for scan in self.frames) else "base"

    def merged(self) -> Scan:
        """One scan of every frame's points (for a report of several frames)."""
        if len(self.frames) == 1:
            return self.frames[0]
        return replace(self.frames[0], points_m=np.vstack([frame.points_m for frame in self.frames]),
                       source=self.source)


@dataclass(frozen=True)
class _Frame:
    """One scan to place: explicit intrinsics file and pose (options or manifest), and the
    sidecar files found beside it."""

    scan: str
    intrinsics: str | None = None
    pose: FramePose | None = None
    sidecar_intrinsics: str | None = None
    sidecar_pose: str | None = None


def place_scans(options: PlacementOptions, recorded: Recorded | None = None, stdin=None) -> Placed:
    """Read and place every scan of `options` (see the module docstring for which source
    of each input wins); InputError for conflicting or incomplete options."""
    frames, manifest_hand_eye = _frames(options)
    hand_eye_path = options.hand_eye if options.hand_eye is not None else manifest_hand_eye
    calibration = read_hand_eye(hand_eye_path) if hand_eye_path is not None else None
    pose_options_given = hand_eye_path is not None or options.robot is not None
    if options.cloud_frame is not None and options.cloud_frame not in FRAMES:
        raise InputError(f"--cloud-frame must be base or camera, got {options.cloud_frame!r}")
    if options.units is not None and options.units not in UNIT_SCALE:
        raise InputError(f"--units must be m or mm, got {options.units!r}")
    origin = parse_vector(options.camera_origin, 3, "--camera-origin") if options.camera_origin else None
    scans, messages, warnings, records, hints = [], [], [], [], []
    for frame in frames:
        data = _stdin_bytes(frame.scan, stdin)
        found = None
        if recorded is not None:
            found = recorded.by_sha256.get(_sha256(frame.scan, data))
            if found is None:
                messages.append(f"{frame.scan}: {recorded.source} was made from another scan: only its parameters "
                                "are used, not its placement")
        scan, frame_messages, frame_warnings, record, hint = _place(
            frame, options, calibration, pose_options_given, origin, found, recorded, data, len(frames) > 1
        )
        hints += [hint] if hint else []
        scans.append(scan)
        messages += frame_messages
        warnings += frame_warnings
        records.append(record)
    source = options.frames if options.frames is not None else ",".join(frame.scan for frame in frames)
    return Placed(tuple(scans), source, tuple(messages), tuple(warnings), tuple(records), tuple(hints))


def _place(frame: _Frame, options, calibration, pose_options_given, origin, found, recorded, data, needs_pose):
    """(Scan, messages, warnings, record, hint or None) of one frame; `found`: its recorded placement."""
    is_depth = frame.scan != "-" and Path(frame.scan).suffix.lower() == ".png"
    sources: dict[str, str] = {}

    unnamed: dict[str, list[str]] = {}  # source -> what was taken from it, for one line each

    def take(kind: str, source: str) -> None:
        """Use an input the user did not name for this scan, and say so."""
        sources[kind] = source
        unnamed.setdefault(source, []).append("camera pose" if kind == "pose" else kind)

    intrinsics = None
    if frame.intrinsics is not None:
        if not is_depth:
            raise InputError(f"{frame.scan}: --intrinsics applies to depth images (.png) only")
        intrinsics, sources["intrinsics"] = read_intrinsics(frame.intrinsics), frame.intrinsics
    elif is_depth and found is not None and found.intrinsics is not None:
        intrinsics = found.intrinsics
        take("intrinsics", f"the record of {recorded.source}")
    elif is_depth and frame.sidecar_intrinsics is not None:
        intrinsics = read_intrinsics(frame.sidecar_intrinsics)
        take("intrinsics", f"{frame.sidecar_intrinsics} (beside the scan)")

    pose, robot, pose_warnings = frame.pose, None, []
    if pose is None and found is not None and not pose_options_given:
        T_base_camera = found.T_base_camera
        take("pose", f"the record of {recorded.source}")
    else:
        if pose is None and frame.sidecar_pose is not None:
            pose = read_pose_file(frame.sidecar_pose)
            take("pose", f"{frame.sidecar_pose} (beside the scan)")
        elif pose is not None:
            sources["pose"] = pose.source
        if calibration is not None:
            sources["hand_eye"] = calibration.source
        T_base_camera, pose_warnings = camera_pose(pose, calibration, options.robot)
        if pose is not None and pose.joints_rad is not None and calibration.setup == "eye-in-hand":
            robot = joints_robot(pose, options.robot)
    messages = [f"{frame.scan}: {' and '.join(kinds)} from {source}" for source, kinds in unnamed.items()]
    if needs_pose and T_base_camera is None:
        raise InputError(f"{frame.scan}: no pose: give {own_pose_name(frame.scan)} or use a --frames manifest")

    def chosen(option, key: str, default):
        if option is not None:
            return option
        return getattr(found, key) if found is not None else default

    cloud_frame = chosen(options.cloud_frame, "cloud_frame", "base")
    units = chosen(options.units, "units", "m")
    camera_origin = chosen(origin, "camera_origin_m", None)
    scan, notes = load_scan(
        frame.scan, intrinsics=intrinsics, intrinsics_source=sources.get("intrinsics", "the intrinsics"),
        T_base_camera=T_base_camera, cloud_frame=cloud_frame,
        camera_origin_m=camera_origin, units=units, stdin=None if data is None else io.BytesIO(data),
    )
    placement = FramePlacement("camera" if is_depth else cloud_frame, units, intrinsics, T_base_camera, camera_origin)
    hint = None
    if not is_depth and T_base_camera is None and camera_origin is None and cloud_frame == "base" and (
            options.cloud_frame is None and found is None):
        hint = camera_frame_hint(scan)
        if hint:
            # A camera's own cloud is seen from its origin: normals oriented toward +z (a camera
            # above) would face away from it, and every concave corner would read as convex.
            scan = replace(scan, camera_origin_m=np.zeros(3))
            placement = replace(placement, camera_origin_m=np.zeros(3))
            sources["camera_origin_m"] = "the origin of a cloud that looks like a camera's own"
            hint += "; its normals are oriented toward the origin, as a camera's own cloud is seen"
    warnings = [*pose_warnings, *notes, *([hint] if hint else [])]
    return scan, messages, warnings, placement_record(placement, robot, sources), hint


def placement_record(placement: FramePlacement, robot: str | None, sources: dict[str, str]) -> dict:
    """The JSON record of one frame's placement: every value that changes the result, exact
    (floats as read or computed, so that a rerun places the scan bit for bit the same), and
    where each came from (`from`: file names, for people)."""
    return {
        "cloud_frame": placement.cloud_frame,
        "units": placement.units,
        "intrinsics": None if placement.intrinsics is None else asdict(placement.intrinsics),
        "T_base_camera": None if placement.T_base_camera is None else placement.T_base_camera.tolist(),
        "camera_origin_m": None if placement.camera_origin_m is None else placement.camera_origin_m.tolist(),
        "robot": robot,
        "from": dict(sorted(sources.items())),
    }


def with_placement(result: RunResult, placed: Placed) -> RunResult:
    """`result` with the frame it is in, each frame's placement in its input record, and the
    placement warnings first among its warnings."""
    record = dict(result.record)
    record["frame"] = placed.frame
    inputs = dict(record.get("input", {}))
    if len(placed.frames) == 1:
        inputs["placement"] = placed.placements[0]
    else:
        inputs["frames"] = [{**frame, "placement": placement}
                            for frame, placement in zip(inputs.get("frames", []), placed.placements)]
    record["input"] = inputs
    return replace(result, record=record, warnings=(*placed.warnings, *result.warnings))


def read_recorded(path: str | Path) -> Recorded | None:
    """The placements recorded in a path JSON (None for any other config file, or a path JSON
    that recorded none); InputError naming the file and key for a malformed record."""
    if Path(path).suffix.lower() != ".json":
        return None
    document = read_json(path, "a path file")
    inputs = document.get("input") if isinstance(document, dict) else None
    if not isinstance(inputs, dict):
        return None
    entries = [(inputs, "input")] if "placement" in inputs else [
        (frame, f"input.frames[{k}]") for k, frame in enumerate(inputs.get("frames") or [])
        if isinstance(frame, dict) and "placement" in frame
    ]
    by_sha256 = {}
    for entry, where in entries:
        sha256 = entry.get("sha256")
        if not isinstance(sha256, str):
            raise InputError(f"{path}: {where}.sha256 must be the scan's sha256")
        by_sha256[sha256] = _frame_placement(entry["placement"], f"{path}: {where}.placement")
    return Recorded(str(path), by_sha256) if by_sha256 else None


def _frame_placement(data, where: str) -> FramePlacement:
    """A FramePlacement from its JSON record; InputError naming the key."""
    if not isinstance(data, dict):
        raise InputError(f"{where} must be an object")
    if data.get("cloud_frame") not in FRAMES or data.get("units") not in UNIT_SCALE:
        raise InputError(f"{where}: cloud_frame must be base or camera and units m or mm")
    intrinsics = data.get("intrinsics")
    T_base_camera = data.get("T_base_camera")
    origin = data.get("camera_origin_m")
    return FramePlacement(
        cloud_frame=data["cloud_frame"],
        units=data["units"],
        intrinsics=None if intrinsics is None else intrinsics_from_json(intrinsics, f"{where}.intrinsics"),
        T_base_camera=None if T_base_camera is None else rigid_transform(T_base_camera, f"{where}.T_base_camera"),
        camera_origin_m=None if origin is None else _vector(origin, f"{where}.camera_origin_m"),
    )


def _vector(values, where: str) -> np.ndarray:
    if not (isinstance(values, list) and len(values) == 3 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in values)):
        raise InputError(f"{where} must be 3 finite numbers")
    return np.array(values, dtype=np.float64)


def _stdin_bytes(scan: str, stdin) -> bytes | None:
    """The bytes of a scan read from stdin (read once, so that it can be hashed and parsed)."""
    return (stdin or sys.stdin.buffer).read() if scan == "-" else None


def _sha256(scan: str, data: bytes | None) -> str:
    return hashlib.sha256(data if data is not None else read_input(scan, "a scan")).hexdigest()


def _frames(options: PlacementOptions) -> tuple[list[_Frame], str | None]:
    """The frames to place and the manifest's hand-eye file: one frame from the options (with
    its sidecars), several from the positional scans (poses beside them) or from a --frames
    manifest. Options that conflict are one InputError naming them."""
    given = [name for name, value in (("--camera-pose", options.camera_pose), ("--flange-pose", options.flange_pose),
                                      ("--joints", options.joints)) if value is not None]
    if len(given) > 1:
        raise InputError(f"{' and '.join(given)}: give one pose of the camera, not several")
    scans = list(options.scans)
    several = options.frames is not None or len(scans) > 1
    if several and (given or options.camera_origin is not None):
        option = given[0] if given else "--camera-origin"
        raise InputError(f"{option} applies to a single scan; with several frames each has its own pose")
    if options.frames is not None:
        if scans:
            raise InputError(
                f"--frames {options.frames}: give the scans in the manifest or on the command line, not both"
            )
        specs, hand_eye = read_frames_manifest(options.frames)
        return [_Frame(spec.scan, spec.intrinsics or options.intrinsics, spec.pose) for spec in specs], hand_eye
    if not scans:
        raise InputError("no scan given: weldseam plan SCAN [SCAN ...] or weldseam plan --frames FILE.json")
    if len(scans) > 1:
        frames, seen = [], {}
        for scan in scans:
            if scan == "-":
                raise InputError("- (stdin) can only be a single scan")
            intrinsics, pose = sidecars(Path(scan))
            if pose is not None and pose in seen:
                raise InputError(
                    f"{scan} and {seen[pose]} share the pose file {pose}: give each frame its own {own_pose_name(scan)}"
                )
            if pose is not None:
                seen[pose] = scan
            frames.append(_Frame(scan, options.intrinsics, None, _name(intrinsics), _name(pose)))
        return frames, None
    (scan,) = scans
    if options.flange_pose is not None:
        vector = parse_vector(options.flange_pose, 6, "--flange-pose")
        pose = FramePose("--flange-pose", flange_pose=pose_vector_matrix(vector, "--flange-pose"))
    elif options.joints is not None:
        pose = FramePose("--joints", joints_rad=parse_vector(options.joints, 6, "--joints"))
    else:
        pose = read_pose_file(options.camera_pose) if options.camera_pose is not None else None
    intrinsics, pose_beside = sidecars(Path(scan)) if scan != "-" else (None, None)
    return [_Frame(scan, options.intrinsics, pose, _name(intrinsics), _name(pose_beside))], None


def _name(path: Path | None) -> str | None:
    return None if path is None else str(path)
