"""Weld path files: write a run's paths as JSON or CSV (byte-deterministic), read them back.

JSON holds everything (record, timings, warnings, per-seam metadata, poses with both a
quaternion and a UR rotation vector). CSV holds one row per pose: `seam,x,y,z,rx,ry,rz`
or `seam,x,y,z,qx,qy,qz,qw`. Positions in metres, base frame; numbers rounded to 9
decimals (1 nm), so the same result always gives the same bytes.
"""

from __future__ import annotations

from dataclasses import replace

import io
import json
import sys
import warnings
from pathlib import Path
from typing import BinaryIO

import numpy as np
from scipy.spatial.transform import Rotation

from weldseam import __version__
from weldseam.errors import InputError
from weldseam.io.files import read_input
from weldseam.geometry import quaternions_continuous, rotation_vectors
from weldseam.io.atomic import atomic_write
from weldseam.types import RunResult, WeldPath

DECIMALS = 9
POSE_KEYS = ("x", "y", "z", "qx", "qy", "qz", "qw", "rx", "ry", "rz")
ROTATION_COLUMNS = {"rotvec": ("rx", "ry", "rz"), "quat": ("qx", "qy", "qz", "qw")}
FORMATS = ("json", "csv")


def format_path_json(result: RunResult) -> bytes:
    """The paths of `result` as a UTF-8 `weldseam.path` JSON document (2-space indent).

    Keys: format, version, frame (result.record["frame"]: "base", or "camera" for a scan
    that nothing placed), units ("m"), input and params (from result.record), timings_s,
    warnings, candidates (every seam candidate: centre, length, the seam it became or why it
    was rejected), seams (id, closed, joint, confidence, length_m, tacks (each tack weld's
    middle_m and length_m), poses of x y z qx qy qz qw
    rx ry rz). Quaternions are hemisphere-continuous along each seam, rotation vectors have
    angle <= pi. Input and params are written exactly (each float as the shortest text that
    reads back to it), so that they place and plan a rerun bit for bit the same; the rest is
    rounded to DECIMALS.
    """
    document = {
        "format": "weldseam.path",
        "version": __version__,
        "frame": result.record.get("frame", "base"),
        "units": "m",
        "input": _plain(result.record.get("input", {})),
        "params": _plain(result.record.get("params", {})),
        **_rounded({
            "timings_s": result.timings_s,
            "warnings": list(result.warnings),
            "candidates": result.record.get("candidates", []),
            "seams": [
                {"id": path.seam_id, "closed": bool(path.closed), "joint": path.joint,
                 "confidence": path.confidence, "length_m": path.length_m,
                 "tacks": [tack.as_record() for tack in path.tacks]}
                for path in result.paths
            ],
        }),
    }
    for seam, path in zip(document["seams"], result.paths):
        confidence = np.ones(len(path.positions_m)) if path.pose_confidence is None else path.pose_confidence
        seam["poses"] = [{**dict(zip(POSE_KEYS, row)), "confidence": round(float(c), 3)}
                         for row, c in zip(_pose_table(path).tolist(), confidence)]  # fmt: skip
    text = json.dumps(document, indent=2, ensure_ascii=False, allow_nan=False)
    return (text + "\n").encode("utf-8")


def format_path_csv(result: RunResult, rotation: str = "rotvec") -> bytes:
    """The poses of `result` as CSV, one row per pose, "\\n" line endings.

    rotation: "rotvec" for `seam,x,y,z,rx,ry,rz` (UR pose vectors) or "quat" for
    `seam,x,y,z,qx,qy,qz,qw`. Numbers have exactly 9 decimals. Seam metadata (closed,
    joint, confidence) is only in the JSON format.
    """
    names = _rotation_columns(rotation)
    columns = [0, 1, 2] + [POSE_KEYS.index(name) for name in names]
    tables = [_pose_table(path) for path in result.paths]
    rows = [np.column_stack([np.full(len(table), path.seam_id), table[:, columns]])
            for path, table in zip(result.paths, tables)]
    buffer = io.BytesIO()
    buffer.write((",".join(("seam", "x", "y", "z") + names) + "\n").encode("ascii"))
    np.savetxt(
        buffer, np.concatenate(rows or [np.empty((0, len(columns) + 1))]),
        fmt="%d" + f",%.{DECIMALS}f" * len(columns), newline="\n",
    )
    return buffer.getvalue()


def write_paths(
    result: RunResult,
    out: str | Path,
    *,
    fmt: str | None = None,
    rotation: str = "rotvec",
    stdout: BinaryIO | None = None,
) -> None:
    """Write the paths of `result` to `out`, atomically.

    fmt: "json" or "csv"; None picks it from the extension of `out` (.json or .csv).
    out: a file path, or "-" for `stdout` (default sys.stdout.buffer); with "-" and no
        fmt the format is CSV.
    rotation: CSV rotation columns, "rotvec" or "quat" (JSON always has both).
    """
    fmt = path_format(out, fmt)
    _rotation_columns(rotation)
    data = format_path_json(result) if fmt == "json" else format_path_csv(result, rotation)
    if str(out) == "-":
        stream = stdout or sys.stdout.buffer
        stream.write(data)
        stream.flush()
    else:
        atomic_write(out, data)


def path_format(out: str | Path, fmt: str | None = None) -> str:
    """The format ("json" or "csv") a path file `out` is written in: `fmt`, else its extension
    (CSV for "-", stdout). InputError for anything else, so it can be checked before a run."""
    if fmt is None:
        suffix = Path(out).suffix.lower()
        fmt = "csv" if str(out) == "-" else suffix[1:]
        if fmt not in FORMATS:
            raise InputError(
                f"{out}: unknown path file format {suffix or '(no extension)'!r} "
                f"(use .json or .csv)"
            )
    if fmt not in FORMATS:
        raise InputError(f"format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    return fmt


def read_paths(path: str | Path) -> list[WeldPath]:
    """Read paths back from our JSON, or from a CSV with x, y, z and either rx, ry, rz or
    qx, qy, qz, qw columns (header row required; a `seam` column is optional, rows are
    grouped by it in order of first appearance). JSON poses keep their confidence (1 where a
    pose has none); CSV paths get closed=False, joint None (a CSV names no joint kind: unknown),
    confidence 1.0 and no pose confidence (None: all 1). Raises InputError for anything unreadable."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".json", ".csv"):
        raise InputError(
            f"{path}: unknown path file format {suffix or '(no extension)'!r} (use .json or .csv)"
        )
    try:
        text = read_input(path, "a path file").decode("utf-8-sig")  # -sig: accept a spreadsheet BOM
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text") from None
    if not text.strip():
        raise InputError(f"{path}: the file is empty")
    return _read_json(text, path) if suffix == ".json" else _read_csv(text, path)


def _rotation_columns(rotation: str) -> tuple[str, ...]:
    """The CSV rotation column names for "rotvec" or "quat"."""
    if rotation not in ROTATION_COLUMNS:
        raise InputError(f"rotation: expected 'rotvec' or 'quat', got {rotation!r}")
    return ROTATION_COLUMNS[rotation]


def _pose_table(path: WeldPath) -> np.ndarray:
    """(K, 10) x y z qx qy qz qw rx ry rz of a path, rounded to DECIMALS, no -0.0."""
    positions = np.asarray(path.positions_m, dtype=np.float64).reshape(-1, 3)
    rotations = np.asarray(path.rotations, dtype=np.float64).reshape(-1, 3, 3)
    if len(rotations) != len(positions):
        raise ValueError(
            f"seam {path.seam_id}: {len(positions)} positions but {len(rotations)} rotations"
        )
    table = np.hstack([positions, quaternions_continuous(rotations), rotation_vectors(rotations)])
    if not np.isfinite(table).all():
        raise ValueError(f"seam {path.seam_id}: the path has NaN or infinite poses")
    return np.round(table, DECIMALS) + 0.0


def _plain(value):
    """`value` as plain JSON data (numpy arrays and scalars converted, tuples to lists), floats
    unchanged but -0.0 made 0.0."""
    if isinstance(value, dict):
        return {str(key): _plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value + 0.0
    return value


def _rounded(value):
    """`value` as plain JSON data (numpy arrays and scalars converted, tuples to lists)
    with every float rounded to DECIMALS and -0.0 made 0.0."""
    if isinstance(value, dict):
        return {str(key): _rounded(item) for key, item in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_rounded(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return round(value, DECIMALS) + 0.0
    return value


def _weld_path(path: Path, seam_id: int, table: np.ndarray, rotation: str, **metadata):
    """A WeldPath from rows of x y z and rotation vector or quaternion columns."""
    if not np.isfinite(table).all():
        raise InputError(f"{path}: seam {seam_id} has NaN or infinite values")
    try:
        if rotation == "quat":
            matrices = Rotation.from_quat(table[:, 3:7]).as_matrix()
        else:
            matrices = Rotation.from_rotvec(table[:, 3:6]).as_matrix()
    except ValueError:
        raise InputError(f"{path}: seam {seam_id} has a zero-length quaternion") from None
    return WeldPath(
        seam_id=seam_id, positions_m=np.ascontiguousarray(table[:, :3]),
        rotations=matrices, **metadata,
    )


def _read_json(text: str, path: Path) -> list[WeldPath]:
    """Paths from a `weldseam.path` JSON document."""
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise InputError(f"{path}: not valid JSON ({error})") from None
    if not isinstance(document, dict) or document.get("format") != "weldseam.path":
        raise InputError(f'{path}: not a weldseam path file (no "format": "weldseam.path")')
    seams = document.get("seams")
    if not isinstance(seams, list) or not all(isinstance(seam, dict) for seam in seams):
        raise InputError(f'{path}: "seams" must be a list of objects')
    paths = []
    for index, seam in enumerate(seams):
        seam_id = seam.get("id", index)
        closed, joint = seam.get("closed", False), seam.get("joint")
        confidence = seam.get("confidence", 1.0)
        if not (type(seam_id) is int and type(closed) is bool and (joint is None or isinstance(joint, str))
                and type(confidence) in (int, float)):
            raise InputError(
                f"{path}: seam {index}: id must be an integer, closed a boolean, joint a "
                f"string (or null: unknown) and confidence a number"
            )
        try:
            table = np.array(
                [[pose[key] for key in POSE_KEYS[:7]] for pose in seam["poses"]], dtype=np.float64
            ).reshape(-1, 7)
        except (KeyError, TypeError, ValueError):
            raise InputError(
                f"{path}: seam {seam_id}: poses must be a list of objects with numbers "
                f"{', '.join(POSE_KEYS[:7])}"
            ) from None
        pose_confidence = [pose.get("confidence", 1.0) for pose in seam["poses"]]
        if not all(type(c) in (int, float) and 0 <= c <= 1 for c in pose_confidence):
            raise InputError(f"{path}: seam {seam_id}: a pose's confidence must be a number from 0 to 1")
        pose_confidence = np.array(pose_confidence, dtype=np.float64)
        paths.append(replace(_weld_path(
            path, seam_id, table, "quat", closed=closed, joint=joint, confidence=float(confidence),
        ), pose_confidence=pose_confidence))
    return paths


def _read_csv(text: str, path: Path) -> list[WeldPath]:
    """Paths from a CSV with a header row naming x, y, z and rotation columns."""
    header_line, _, body = text.partition("\n")
    names = [name.strip().lower() for name in header_line.split(",")]
    rotation = next((kind for kind in ("quat", "rotvec")
                     if set(ROTATION_COLUMNS[kind]) <= set(names)), None)
    if not {"x", "y", "z"} <= set(names) or rotation is None:
        raise InputError(
            f"{path}: the CSV header must name x, y, z and either rx, ry, rz or qx, qy, qz, qw "
            f"(it has: {header_line.strip()})"
        )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "input contained no data": see below
        try:
            rows = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2, comments="#")
        except ValueError as error:
            raise InputError(f"{path}: not numeric CSV data ({error})") from None
    if len(rows) == 0:
        raise InputError(f"{path}: the CSV has no poses")
    if rows.shape[1] != len(names):
        raise InputError(
            f"{path}: the CSV rows have {rows.shape[1]} columns, the header {len(names)}"
        )
    wanted = ("x", "y", "z") + ROTATION_COLUMNS[rotation]
    table = rows[:, [names.index(name) for name in wanted]]
    seam_ids = rows[:, names.index("seam")] if "seam" in names else np.zeros(len(rows))
    if not np.array_equal(seam_ids, np.round(seam_ids)):
        raise InputError(f"{path}: the seam column must hold integers")
    unique, first = np.unique(seam_ids, return_index=True)
    return [
        _weld_path(path, int(seam_id), table[seam_ids == seam_id], rotation)
        for seam_id in unique[np.argsort(first)]
    ]
