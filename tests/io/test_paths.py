"""Tests for weldseam.io.paths and weldseam.io.atomic: deterministic JSON/CSV path files,
round trips, stdout, and no partial or temporary file left behind on failure."""

from __future__ import annotations

import io
import json
import os
import re
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import weldseam
from weldseam.errors import InputError
from weldseam.io import atomic
from weldseam.io.atomic import atomic_write
from weldseam.io.paths import format_path_csv, format_path_json, read_paths, write_paths
from weldseam.types import RunResult, Tack, WeldPath


def make_result() -> RunResult:
    """An open seam whose frames turn through 180 degrees about z (quaternion signs would
    flip without the hemisphere rule), and a closed ring with the torch pointing down."""
    steps = np.linspace(0.0, 1.0, 21)
    line = np.column_stack([0.3 + 0.2 * steps, 0.1 * steps, np.full(21, 0.05)])
    turn = Rotation.from_euler("zx", np.column_stack([np.radians(150 + 60 * steps),
                                                      np.full(21, np.pi)])).as_matrix()
    angles = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
    ring = np.column_stack([0.5 + 0.05 * np.cos(angles), 0.05 * np.sin(angles), np.full(16, 0.1)])
    down = Rotation.from_euler("xz", np.column_stack([np.full(16, np.pi), angles])).as_matrix()
    return RunResult(
        paths=(
            WeldPath(0, line, turn, closed=False, joint="v_groove", confidence=0.9312345678912,
                     tacks=(Tack((0.4, 0.05, 0.05), 0.0083),)),
            WeldPath(1, ring, down, closed=True, joint="fillet", confidence=0.5),
        ),
        record={"input": {"scan": "scan.ply", "sha256": "ab" * 32},
                "params": {"normals": {"radius_m": 0.01},
                           "camera_origin_m": np.array([0.0, 0.1, 0.7])}},
        timings_s={"read": 0.0123456789123, "total": 1.5},
        warnings=("seam 1 is short",),
    )


def assert_same_paths(read: list[WeldPath], written: tuple[WeldPath, ...]) -> None:
    assert [path.seam_id for path in read] == [path.seam_id for path in written]
    for got, expected in zip(read, written):
        np.testing.assert_allclose(got.positions_m, expected.positions_m, rtol=0, atol=1e-9)
        np.testing.assert_allclose(got.rotations, expected.rotations, rtol=0, atol=1e-8)


def test_json_layout():
    result = make_result()
    document = json.loads(format_path_json(result))
    assert list(document) == ["format", "version", "frame", "units", "input", "params",
                              "timings_s", "warnings", "candidates", "seams"]
    assert document["format"] == "weldseam.path" and document["version"] == weldseam.__version__
    assert (document["frame"], document["units"]) == ("base", "m")
    assert document["input"] == result.record["input"]
    assert document["params"] == {"normals": {"radius_m": 0.01}, "camera_origin_m": [0.0, 0.1, 0.7]}
    assert document["timings_s"] == {"read": 0.012345679, "total": 1.5}
    assert document["warnings"] == ["seam 1 is short"]
    first, ring = document["seams"]
    assert list(first) == ["id", "closed", "joint", "confidence", "length_m", "tacks", "poses"]
    assert first["tacks"] == [{"middle_m": [0.4, 0.05, 0.05], "length_m": 0.0083}] and ring["tacks"] == []
    assert (first["id"], first["closed"], first["joint"], first["confidence"]) == (
        0, False, "v_groove", 0.931234568)
    assert (ring["id"], ring["closed"], ring["joint"]) == (1, True, "fillet")
    assert ring["length_m"] == pytest.approx(result.paths[1].length_m, abs=1e-9)
    assert list(first["poses"][0]) == ["x", "y", "z", "qx", "qy", "qz", "qw", "rx", "ry", "rz", "confidence"]
    assert len(first["poses"]) == 21 and len(ring["poses"]) == 16


def test_json_rotations_are_continuous_quaternions_and_short_rotation_vectors():
    document = json.loads(format_path_json(make_result()))
    for seam in document["seams"]:
        poses = seam["poses"]
        quats = np.array([[pose[key] for key in ("qx", "qy", "qz", "qw")] for pose in poses])
        rotvecs = np.array([[pose[key] for key in ("rx", "ry", "rz")] for pose in poses])
        assert quats[0, 3] >= 0 and (np.sum(quats[1:] * quats[:-1], axis=1) >= 0).all()
        assert (np.linalg.norm(rotvecs, axis=1) <= np.pi + 1e-9).all()


def test_numbers_are_rounded_to_nine_decimals():
    text = format_path_json(make_result()).decode()
    decimals = [len(number) for number in re.findall(r"\d\.(\d+)", text)]
    assert max(decimals) <= 9 and "-0.0," not in text
    csv_rows = format_path_csv(make_result()).decode().splitlines()[1:]
    assert all(re.fullmatch(r"\d+(,-?\d+\.\d{9}){6}", row) for row in csv_rows)


def test_output_is_byte_identical_for_the_same_input(tmp_path):
    assert format_path_json(make_result()) == format_path_json(make_result())
    for rotation in ("rotvec", "quat"):
        assert format_path_csv(make_result(), rotation) == format_path_csv(make_result(), rotation)
    write_paths(make_result(), tmp_path / "a.json")
    write_paths(make_result(), tmp_path / "b.json")
    assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()


def test_csv_layout():
    rotvec = format_path_csv(make_result()).decode()
    quat = format_path_csv(make_result(), rotation="quat").decode()
    assert rotvec.startswith("seam,x,y,z,rx,ry,rz\n0,0.300000000,0.000000000,0.050000000,")
    assert quat.startswith("seam,x,y,z,qx,qy,qz,qw\n0,")
    assert "\r" not in rotvec and rotvec.endswith("\n")
    assert len(rotvec.splitlines()) == 1 + 21 + 16 and rotvec.splitlines()[-1].startswith("1,")


@pytest.mark.parametrize("name, fmt, rotation", [
    ("path.json", None, "rotvec"),
    ("path.JSON", None, "rotvec"),
    ("path.csv", None, "rotvec"),
    ("path.csv", None, "quat"),
    ("path.out", "csv", "quat"),
])
def test_round_trip(tmp_path, name, fmt, rotation):
    result = make_result()
    out = tmp_path / name
    write_paths(result, str(out), fmt=fmt, rotation=rotation)
    if fmt is not None:  # read_paths dispatches on the extension only
        out = out.rename(out.with_suffix(f".{fmt}"))
    read = read_paths(out)
    assert_same_paths(read, result.paths)
    if out.suffix.lower() == ".json":
        assert [(p.closed, p.joint, p.confidence) for p in read] == [
            (False, "v_groove", 0.931234568), (True, "fillet", 0.5)]
    else:  # a CSV names no joint kind: unknown, never a guessed one
        assert [(p.closed, p.joint, p.confidence) for p in read] == [(False, None, 1.0), (False, None, 1.0)]
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]


def test_pose_confidence_reads_back_from_json_and_is_none_from_csv(tmp_path):
    result = make_result()
    unsure = np.where(np.arange(21) % 4 == 0, 0.3, np.where(np.arange(21) % 4 == 1, 0.7, 1.0))
    result = RunResult(paths=(replace(result.paths[0], pose_confidence=unsure), result.paths[1]), record=result.record)
    write_paths(result, tmp_path / "p.json")
    write_paths(result, tmp_path / "p.csv")
    first, ring = read_paths(tmp_path / "p.json")
    assert first.pose_confidence.tolist() == unsure.tolist()
    assert ring.pose_confidence.tolist() == [1.0] * 16  # a path without any is written as all 1
    assert [path.pose_confidence for path in read_paths(tmp_path / "p.csv")] == [None, None]  # CSV has no column


def test_write_to_stdout_defaults_to_csv():
    stdout = io.BytesIO()
    write_paths(make_result(), "-", stdout=stdout)
    assert stdout.getvalue() == format_path_csv(make_result())
    stdout = io.BytesIO()
    write_paths(make_result(), "-", fmt="json", stdout=stdout)
    assert stdout.getvalue() == format_path_json(make_result())


def test_write_errors_name_the_problem(tmp_path):
    with pytest.raises(InputError, match=r"^.*path\.txt: unknown path file format '\.txt' "
                                         r"\(use \.json or \.csv\)$"):
        write_paths(make_result(), str(tmp_path / "path.txt"))
    with pytest.raises(InputError, match=r"^format: expected one of json, csv, got 'yaml'$"):
        write_paths(make_result(), str(tmp_path / "path.json"), fmt="yaml")
    with pytest.raises(InputError, match=r"^rotation: expected 'rotvec' or 'quat', got 'euler'$"):
        write_paths(make_result(), str(tmp_path / "path.csv"), rotation="euler")
    missing = tmp_path / "no" / "such" / "dir" / "path.csv"
    with pytest.raises(InputError, match=rf"^{re.escape(str(missing))}: cannot write "
                                         rf"\(No such file or directory\)$"):
        write_paths(make_result(), str(missing))
    assert list(tmp_path.iterdir()) == []


def test_a_path_with_nan_is_refused_and_nothing_written(tmp_path):
    bad = WeldPath(0, np.array([[0.0, 0.0, np.nan]]), np.eye(3)[None])
    with pytest.raises(ValueError, match="seam 0: the path has NaN or infinite poses"):
        write_paths(RunResult(paths=(bad,)), str(tmp_path / "path.json"))
    assert list(tmp_path.iterdir()) == []


def test_empty_result_and_empty_path():
    empty = RunResult(paths=(WeldPath(3, np.empty((0, 3)), np.empty((0, 3, 3))),))
    assert format_path_csv(RunResult(paths=())) == b"seam,x,y,z,rx,ry,rz\n"
    assert format_path_csv(empty) == b"seam,x,y,z,rx,ry,rz\n"
    assert json.loads(format_path_json(empty))["seams"][0]["poses"] == []


# --- reading other CSVs and bad files --------------------------------------------------


def test_reads_a_foreign_csv_without_seam_column(tmp_path):
    path = tmp_path / "robot.csv"
    path.write_text(" QW , x,y,z, qx,qy,qz\n1,0.1,0.2,0.3,0,0,0\n0,0.4,0.5,0.6,1,0,0\n")
    (read,) = read_paths(path)
    assert read.seam_id == 0 and not read.closed
    np.testing.assert_array_equal(read.positions_m, [[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]])
    np.testing.assert_allclose(read.rotations[1], np.diag([1.0, -1.0, -1.0]), atol=1e-15)


def test_csv_rows_are_grouped_by_seam_in_order_of_appearance(tmp_path):
    path = tmp_path / "mixed.csv"
    path.write_text("seam,x,y,z,rx,ry,rz\n5,1,0,0,0,0,0\n2,2,0,0,0,0,0\n5,3,0,0,0,0,0\n")
    five, two = read_paths(path)
    assert (five.seam_id, two.seam_id) == (5, 2)
    np.testing.assert_array_equal(five.positions_m[:, 0], [1, 3])


def expect_error(path, problem: str) -> None:
    with pytest.raises(InputError) as info:
        read_paths(path)
    assert re.fullmatch(re.escape(f"{path}: ") + problem, str(info.value)), str(info.value)


@pytest.mark.parametrize("name, content, problem", [
    ("p.csv", "", "the file is empty"),
    ("p.csv", "seam,x,y,z,rx,ry\n1,2,3,4,5,6\n",
     r"the CSV header must name x, y, z and either rx, ry, rz or qx, qy, qz, qw "
     r"\(it has: seam,x,y,z,rx,ry\)"),
    ("p.csv", "seam,x,y,z,rx,ry,rz\n", "the CSV has no poses"),
    ("p.csv", "seam,x,y,z,rx,ry,rz\n0,1,2,3,0,0,zero\n",
     r"not numeric CSV data \(could not convert string 'zero' to float64 at row 0, "
     r"column 7\.\)"),
    ("p.csv", "seam,x,y,z,rx,ry,rz\n0,1,2,3,0,0\n",
     r"the CSV rows have 6 columns, the header 7"),
    ("p.csv", "seam,x,y,z,rx,ry,rz\n0.5,1,2,3,0,0,0\n", "the seam column must hold integers"),
    ("p.csv", "x,y,z,qx,qy,qz,qw\n1,2,3,0,0,0,0\n", "seam 0 has a zero-length quaternion"),
    ("p.csv", "x,y,z,rx,ry,rz\n1,nan,3,0,0,0\n", "seam 0 has NaN or infinite values"),
    ("p.json", "[1", r"not valid JSON \(.*\)"),
    ("p.json", '{"format": "other"}',
     r'not a weldseam path file \(no "format": "weldseam\.path"\)'),
    ("p.json", '{"format": "weldseam.path", "seams": {}}', r'"seams" must be a list of objects'),
    ("p.json", '{"format": "weldseam.path", "seams": [{"id": "0", "poses": []}]}',
     "seam 0: id must be an integer, closed a boolean, joint a string \\(or null: unknown\\) and confidence a number"),
    ("p.json", '{"format": "weldseam.path", "seams": [{"id": 4, "poses": [{"x": 1}]}]}',
     "seam 4: poses must be a list of objects with numbers x, y, z, qx, qy, qz, qw"),
    ("p.json", '{"format": "weldseam.path", "seams": [{"id": 4, "poses": [{"x": 1, "y": 2, "z": 3, "qx": 0, '
     '"qy": 0, "qz": 0, "qw": 1, "confidence": 1.5}]}]}',
     "seam 4: a pose's confidence must be a number from 0 to 1"),
    ("p.yaml", "a: 1", r"unknown path file format '\.yaml' \(use \.json or \.csv\)"),
])
def test_bad_path_files(tmp_path, name, content, problem):
    path = tmp_path / name
    path.write_text(content)
    expect_error(path, problem)


def test_missing_path_file_and_directory(tmp_path):
    expect_error(tmp_path / "none.csv", "no such file")
    folder = tmp_path / "dir.json"
    folder.mkdir()
    expect_error(folder, "is a directory, not a path file")


# --- atomic_write --------------------------------------------------------------------


def test_atomic_write_replaces_and_uses_normal_permissions(tmp_path):
    path = tmp_path / "out.bin"
    atomic_write(path, b"old")
    atomic_write(str(path), b"new")
    assert path.read_bytes() == b"new"
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask
    assert [p.name for p in tmp_path.iterdir()] == ["out.bin"]


def test_atomic_write_failing_data_leaves_old_file_and_no_temp(tmp_path):
    path = tmp_path / "out.csv"
    path.write_bytes(b"old")
    with pytest.raises(TypeError):
        atomic_write(path, "text is not bytes")  # fails after the temp file exists
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_atomic_write_os_failure_is_an_input_error_and_cleans_up(tmp_path, monkeypatch):
    def full_disk(descriptor):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(atomic.os, "fsync", full_disk)
    path = tmp_path / "path.json"
    with pytest.raises(InputError, match=rf"^{re.escape(str(path))}: cannot write "
                                         rf"\(No space left on device\)$"):
        write_paths(make_result(), str(path))
    assert list(tmp_path.iterdir()) == []


def test_a_stop_signal_handled_as_the_temp_file_is_made_leaves_no_temp(tmp_path, monkeypatch):
    """A signal arriving during os.open is handled as the call returns, with the file made: a batch
    worker's SIGTERM then raises SystemExit there (batch_workers._exit_cleanly)."""
    real_open = atomic.os.open

    def open_then_stopped(*args):
        os.close(real_open(*args))
        raise SystemExit(143)

    monkeypatch.setattr(atomic.os, "open", open_then_stopped)
    path = tmp_path / "part0.json"
    with pytest.raises(SystemExit):
        atomic_write(path, b"data")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root ignores permissions")
def test_atomic_write_read_only_directory(tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        with pytest.raises(InputError,
                           match=r"locked/out\.csv: cannot write \(Permission denied\)$"):
            atomic_write(folder / "out.csv", b"data")
        assert list(folder.iterdir()) == []
    finally:
        folder.chmod(0o700)


def test_atomic_write_onto_a_directory_cleans_up(tmp_path):
    target = tmp_path / "taken"
    target.mkdir()
    with pytest.raises(InputError, match=rf"^{re.escape(str(target))}: cannot write \(.+\)$"):
        atomic_write(target, b"data")
    assert [p.name for p in tmp_path.iterdir()] == ["taken"] and list(target.iterdir()) == []


def test_atomic_write_permission_denied_message(tmp_path, monkeypatch):
    """Root ignores directory permissions, so refuse the temp file the way a read-only
    directory does."""
    def refuse(*args):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(atomic.os, "open", refuse)
    path = tmp_path / "out.csv"
    with pytest.raises(InputError, match=rf"^{re.escape(str(path))}: cannot write "
                                         rf"\(Permission denied\)$"):
        atomic_write(path, b"data")
    assert list(tmp_path.iterdir()) == []


def test_reads_a_spreadsheet_csv_with_bom_and_crlf(tmp_path):
    path = tmp_path / "sheet.csv"
    path.write_bytes("\ufeffseam,x,y,z,rx,ry,rz\r\n7,1,2,3,0,0,0\r\n".encode("utf-8"))
    (read,) = read_paths(path)
    assert read.seam_id == 7
    np.testing.assert_array_equal(read.positions_m, [[1.0, 2.0, 3.0]])
