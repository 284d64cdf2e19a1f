"""Tests for weldseam.io.clouds: every format reads back the points written, every bad
file gives one InputError line naming the file and the problem."""

from __future__ import annotations

import hashlib
import io
import re

import numpy as np
import pytest

from weldseam.errors import InputError
from weldseam.io.clouds import lzf_decompress, read_cloud, write_ply

PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4",
             "uint": "u4", "float": "f4", "double": "f8"}


@pytest.fixture
def points() -> np.ndarray:
    """(50, 3) points exactly representable in float32, so every format stores them exactly."""
    rng = np.random.default_rng(7)
    return rng.uniform(-0.5, 0.5, (50, 3)).astype(np.float32).astype(np.float64)


def make_ply(file_format: str, elements) -> bytes:
    """A PLY file from [(element name, [(property, type or ("list", count, item))], rows)]."""
    order = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(file_format)
    header, body = ["ply", f"format {file_format} 1.0", "comment test"], []
    for name, props, rows in elements:
        header.append(f"element {name} {len(rows)}")
        header += [f"property list {kind[1]} {kind[2]} {prop}" if isinstance(kind, tuple)
                   else f"property {kind} {prop}" for prop, kind in props]
        for row in rows:
            values = []
            for value, (_, kind) in zip(row, props):
                if isinstance(kind, tuple):
                    values += [(len(value), kind[1])] + [(item, kind[2]) for item in value]
                else:
                    values.append((value, kind))
            if order is None:
                body.append(" ".join(repr(value) for value, _ in values).encode() + b"\n")
            else:
                body += [np.array([value], order + PLY_TYPES[kind]).tobytes()
                         for value, kind in values]
    return ("\n".join(header) + "\nend_header\n").encode() + b"".join(body)


def cloud_elements(points: np.ndarray):
    """A polygon element (triangles and quads) before the vertices, vertices with a double
    x, extra properties and a list, and a face element after them."""
    polygons = [[0, 1, 2], [0, 1, 2], [1, 2, 3, 4], [3, 4, 5], [1, 2, 3, 4], [5, 6, 7, 8, 9]]
    vertices = [(float(x), 2.5, int(index % 200), float(y), float(z), [index, index + 1])
                for index, (x, y, z) in enumerate(points)]
    return [
        ("polygon", [("vertex_indices", ("list", "uchar", "int"))], [(p,) for p in polygons]),
        ("vertex", [("x", "double"), ("intensity", "float"), ("red", "uchar"), ("y", "float"),
                    ("z", "float"), ("neighbours", ("list", "int", "uint"))], vertices),
        ("face", [("vertex_indices", ("list", "uchar", "int")), ("flag", "short")],
         [([0, 1, 2], 1)] * 40 + [([0, 1, 2, 3], 2)] * 3 + [([4, 5, 6], 3)] * 30),
    ]


@pytest.mark.parametrize("file_format", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_formats_give_the_points_and_skip_other_data(tmp_path, points, file_format):
    path = tmp_path / "scan.PLY"
    path.write_bytes(make_ply(file_format, cloud_elements(points)))
    read, sha256 = read_cloud(str(path))
    assert read.dtype == np.float64 and read.shape == (50, 3)
    np.testing.assert_array_equal(read, points)
    assert sha256 == hashlib.sha256(path.read_bytes()).hexdigest()


def test_ply_with_integer_coordinates(tmp_path):
    path = tmp_path / "grid.ply"
    rows = [(1, -2, 3), (4, 5, -6)]
    path.write_bytes(make_ply("binary_big_endian", [
        ("vertex", [("x", "short"), ("y", "int"), ("z", "char")], rows)]))
    np.testing.assert_array_equal(read_cloud(str(path))[0], rows)


@pytest.mark.parametrize("encoding", ["ascii", "binary"])
def test_trimesh_mesh_export_reads_back(tmp_path, encoding):
    trimesh = pytest.importorskip("trimesh")
    mesh = trimesh.creation.icosphere(subdivisions=2)
    mesh.visual.vertex_colors = np.random.default_rng(1).integers(0, 255, (len(mesh.vertices), 4))
    path = tmp_path / f"mesh_{encoding}.ply"
    mesh.export(path, encoding=encoding)
    assert b"element face" in path.read_bytes()[:400]
    np.testing.assert_allclose(read_cloud(str(path))[0], mesh.vertices, atol=1e-6)


@pytest.mark.parametrize("suffix, options", [
    (".ply", {"write_ascii": True}),
    (".ply", {"write_ascii": False}),
    (".pcd", {"write_ascii": True}),
    (".pcd", {"write_ascii": False}),
    (".pcd", {"write_ascii": False, "compressed": True}),
])
def test_open3d_files_read_back(tmp_path, suffix, options):
    o3d = pytest.importorskip("open3d")
    rng = np.random.default_rng(3)
    written = rng.uniform(-1.0, 1.0, (2000, 3))
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(written))
    cloud.colors = o3d.utility.Vector3dVector(rng.uniform(0.0, 1.0, (2000, 3)))
    cloud.normals = o3d.utility.Vector3dVector(np.tile([0.0, 0.0, 1.0], (2000, 1)))
    path = tmp_path / f"cloud{suffix}"
    assert o3d.io.write_point_cloud(str(path), cloud, **options)
    # Open3D stores PCD coordinates as float32 and ascii PLY with limited digits.
    np.testing.assert_allclose(read_cloud(str(path))[0], written, atol=1e-6)


def test_compressed_pcd_of_a_whole_frame_reads_exactly(tmp_path):
    o3d = pytest.importorskip("open3d")
    rng = np.random.default_rng(0)
    u, v = np.meshgrid(np.arange(640), np.arange(469))
    depth = 0.4 + 0.001 * rng.standard_normal(u.shape)
    written = np.column_stack([(u.ravel() - 320) * depth.ravel() / 620,
                               (v.ravel() - 240) * depth.ravel() / 620, depth.ravel()])
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(written))
    cloud.colors = o3d.utility.Vector3dVector(rng.uniform(0.0, 1.0, written.shape))
    path = tmp_path / "frame.pcd"
    o3d.io.write_point_cloud(str(path), cloud, write_ascii=False, compressed=True)
    read, _ = read_cloud(str(path))
    np.testing.assert_allclose(read, written.astype(np.float32), atol=0)
    assert len(read) == 300160


def test_pcd_with_padding_fields_and_counts(tmp_path, points):
    header = ("# .PCD v0.7\nVERSION 0.7\nFIELDS _ x y normal z _\nSIZE 1 4 8 4 2 1\n"
              "TYPE U F F F I U\nCOUNT 2 1 1 3 1 1\nWIDTH 50\nHEIGHT 1\n"
              "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 50\nDATA binary\n")
    records = np.zeros(50, dtype=[("pad", "u1", (2,)), ("x", "<f4"), ("y", "<f8"),
                                  ("n", "<f4", (3,)), ("z", "<i2"), ("pad2", "u1")])
    records["x"], records["y"], records["z"] = points[:, 0], points[:, 1], np.arange(50)
    path = tmp_path / "padded.pcd"
    path.write_bytes(header.encode() + records.tobytes())
    np.testing.assert_array_equal(read_cloud(str(path))[0],
                                  np.column_stack([points[:, :2], np.arange(50)]))


def test_text_clouds_whitespace_commas_comments_and_extra_columns(tmp_path, points):
    spaced = tmp_path / "scan.xyz"
    spaced.write_text("# x y z r g b\n" + "".join(
        f"{x!r}\t{y!r}  {z!r} 255 0 0\n" for x, y, z in points.tolist()))
    commas = tmp_path / "scan.TXT"
    commas.write_text("".join(f"{x!r}, {y!r},{z!r}\r\n" for x, y, z in points.tolist()) + "# end\n")
    np.testing.assert_array_equal(read_cloud(str(spaced))[0], points)
    np.testing.assert_array_equal(read_cloud(str(commas))[0], points)


@pytest.mark.parametrize("array", [
    np.arange(12, dtype=np.int32).reshape(4, 3),
    np.arange(24, dtype=np.float32).reshape(4, 6),
])
def test_npy_takes_the_first_three_columns(tmp_path, array):
    path = tmp_path / "scan.npy"
    np.save(path, array)
    read, _ = read_cloud(str(path))
    assert read.dtype == np.float64
    np.testing.assert_array_equal(read, array[:, :3])


def test_stdin_is_a_ply(points):
    data = make_ply("binary_little_endian", cloud_elements(points))
    read, sha256 = read_cloud("-", stdin=io.BytesIO(data))
    np.testing.assert_array_equal(read, points)
    assert sha256 == hashlib.sha256(data).hexdigest()


def test_non_finite_points_are_kept(tmp_path, points):
    points[3] = [np.nan, 0.0, 0.0]
    points[4] = [0.0, np.inf, 0.0]
    path = tmp_path / "holes.npy"
    np.save(path, points)
    read, _ = read_cloud(str(path))
    np.testing.assert_array_equal(read, points)


def test_write_ply_round_trip_with_values_and_colors(tmp_path, points):
    path = tmp_path / "debug.ply"
    colors = np.random.default_rng(2).integers(0, 256, (50, 3))
    write_ply(path, points, values=np.arange(50) / 7.0, colors=colors)
    data = path.read_bytes()
    header = data[: data.index(b"end_header")].decode()
    assert "format binary_little_endian 1.0" in header
    assert ("property float value\nproperty uchar red\nproperty uchar green\n"
            "property uchar blue\n") in header
    np.testing.assert_array_equal(read_cloud(str(path))[0], points)
    records = np.frombuffer(data[data.index(b"end_header\n") + 11:],
                            dtype=[("xyz", "<f4", (3,)), ("value", "<f4"), ("rgb", "u1", (3,))])
    np.testing.assert_allclose(records["value"], np.arange(50) / 7.0, rtol=1e-7)
    np.testing.assert_array_equal(records["rgb"], colors)
    write_ply(path, points, colors=np.full((50, 3), 0.5))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["debug.ply"]


def test_write_ply_is_readable_by_open3d(tmp_path, points):
    o3d = pytest.importorskip("open3d")
    path = tmp_path / "debug.ply"
    write_ply(path, points, colors=np.ones((50, 3)))
    cloud = o3d.io.read_point_cloud(str(path))
    np.testing.assert_array_equal(np.asarray(cloud.points), points)
    np.testing.assert_array_equal(np.asarray(cloud.colors), 1.0)


def test_write_ply_rejects_mismatched_extras(tmp_path, points):
    with pytest.raises(InputError, match=r"^values: expected shape \(50,\), got \(3,\)$"):
        write_ply(tmp_path / "a.ply", points, values=[1, 2, 3])
    with pytest.raises(InputError, match=r"^colors: integer colours must be in 0\.\.255$"):
        write_ply(tmp_path / "a.ply", points, colors=np.full((50, 3), 300))
    assert list(tmp_path.iterdir()) == []


def test_lzf_overlapping_back_reference():
    # literal "ab", then a reference of length 7 (code 5 + 2) at distance 2: "ababababa".
    assert bytes(lzf_decompress(bytes([1]) + b"ab" + bytes([5 << 5, 1]))) == b"ababababa"
    # long reference: length 7 + 3 + 2 = 12 at distance 1.
    assert bytes(lzf_decompress(bytes([0]) + b"z" + bytes([7 << 5, 3, 0]))) == b"z" * 13


# --- errors --------------------------------------------------------------------------


def expect_error(path, problem: str) -> None:
    """read_cloud(path) raises InputError whose whole message is 'PATH: problem...'."""
    with pytest.raises(InputError) as info:
        read_cloud(str(path))
    message = str(info.value)
    assert "\n" not in message
    assert re.fullmatch(re.escape(f"{path}: ") + problem, message), message


def truncate(path, keep: int) -> None:
    path.write_bytes(path.read_bytes()[:keep])


def test_missing_directory_empty_and_unknown_extension(tmp_path):
    expect_error(tmp_path / "nope.ply", "no such file")
    folder = tmp_path / "folder.pcd"
    folder.mkdir()
    expect_error(folder, "is a directory, not a point cloud file")
    empty = tmp_path / "empty.xyz"
    empty.write_bytes(b"")
    expect_error(empty, r"empty input \(0 bytes\)")
    expect_error(tmp_path / "scan.stl",
                 r"unknown point cloud format '\.stl' \(supported: \.ply, \.pcd, \.xyz, \.txt, "
                 r"\.npy, or - for a PLY on stdin\)")
    expect_error(tmp_path / "scan", r"unknown point cloud format '\(no extension\)'.*")


def test_empty_stdin():
    with pytest.raises(InputError, match=r"^stdin: empty input \(0 bytes\)$"):
        read_cloud("-", stdin=io.BytesIO(b""))


@pytest.mark.parametrize("file_format", ["binary_little_endian", "binary_big_endian"])
def test_truncated_binary_ply(tmp_path, points, file_format):
    path = tmp_path / "cut.ply"
    path.write_bytes(make_ply(file_format, cloud_elements(points)))
    truncate(path, -5)  # inside the last face
    expect_error(path, r"truncated PLY \(the data ends in element 'face' at record 72 of 73\)")
    path.write_bytes(make_ply(file_format, [("vertex", [("x", "float"), ("y", "float"),
                                                         ("z", "float")], points.tolist())]))
    truncate(path, -1)
    expect_error(path, r"truncated PLY \(the data ends in element 'vertex' at record 49 of 50\)")


def test_truncated_ascii_ply(tmp_path, points):
    path = tmp_path / "cut.ply"
    path.write_bytes(make_ply("ascii", [("vertex", [("x", "float"), ("y", "float"),
                                                    ("z", "float")], points.tolist())]))
    data = path.read_bytes()
    path.write_bytes(data[: data.rindex(b"\n", 0, -1) + 1])
    expect_error(path, r"truncated PLY \(the header promises 50 data lines, the file has 49\)")


@pytest.mark.parametrize("header, problem", [
    (b"solid mesh\n", r"not a PLY file \(it must start with a 'ply' line\)"),
    (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n",
     r"malformed PLY header \(no end_header line\)"),
    (b"ply\nformat binary_middle_endian 1.0\nend_header\n",
     r"malformed PLY header line 2: 'format binary_middle_endian 1.0' \(format must be one "
     r"of ascii, binary_little_endian, binary_big_endian\)"),
    (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n1\n",
     r"malformed PLY header line 4: 'property float128 x' \(unknown property type\)"),
    (b"ply\nformat ascii 1.0\nelement vertex many\nend_header\n",
     r"malformed PLY header line 3: 'element vertex many' \(expected: element NAME COUNT\)"),
    (b"ply\nelement vertex 1\nproperty float x\nend_header\n1\n",
     r"malformed PLY header \(no format line\)"),
    (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nwhat is this\nend_header\n",
     r"malformed PLY header line 5: 'what is this'"),
    (b"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int v\nend_header\n3 0 1 2\n",
     r"PLY has no vertex element"),
    (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
     b"property float nz\nend_header\n1 2 3\n",
     r"PLY vertex element has no z property \(it has: x, y, nz\)"),
    (b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
     b"property float z\nend_header\n", r"the cloud has no points"),
    (b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
     b"property float z\nend_header\n1 2 3\n1 two 3\n",
     r"PLY vertex data is not numeric x y z text \(could not convert string 'two' to "
     r"float64 at row 1, column 2\.\)"),
    (b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
     b"property float z\nend_header\nnan 2 3\n1 inf 3\n", r"all 2 points are NaN or infinite"),
])
def test_bad_ply(tmp_path, header, problem):
    path = tmp_path / "bad.ply"
    path.write_bytes(header)
    expect_error(path, problem)


def pcd_bytes(points: np.ndarray, data: str, fields: str = "x y z") -> bytes:
    header = (f"VERSION .7\nFIELDS {fields}\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
              f"WIDTH {len(points)}\nHEIGHT 1\nPOINTS {len(points)}\nDATA {data}\n")
    if data == "ascii":
        return (header + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in points.tolist())).encode()
    return header.encode() + points.astype("<f4").tobytes()


def test_truncated_pcd(tmp_path, points):
    path = tmp_path / "cut.pcd"
    path.write_bytes(pcd_bytes(points, "binary"))
    truncate(path, -3)
    expect_error(path, r"truncated PCD \(the header promises 50 points = 600 bytes, "
                       r"only 597 bytes follow\)")
    path.write_bytes(pcd_bytes(points[:49], "ascii").replace(b"WIDTH 49", b"WIDTH 50")
                     .replace(b"POINTS 49", b"POINTS 50"))
    expect_error(path, r"truncated PCD \(the header promises 50 points, the data has 49\)")


def test_truncated_compressed_pcd(tmp_path):
    o3d = pytest.importorskip("open3d")
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.random.rand(100, 3)))
    path = tmp_path / "cut.pcd"
    o3d.io.write_point_cloud(str(path), cloud, write_ascii=False, compressed=True)
    truncate(path, -10)
    expect_error(path, r"truncated PCD \(the header promises \d+ compressed bytes, "
                       r"only \d+ follow\)")


@pytest.mark.parametrize("content, problem", [
    (b"VERSION .7\nFIELDS x y z\n", r"malformed PCD header \(no DATA line\)"),
    (b"VERSION .7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n",
     r"malformed PCD header \(FIELDS, SIZE and TYPE must list the same number of entries\)"),
    (b"VERSION .7\nFIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n",
     r"malformed PCD header \(unsupported TYPE/SIZE F3; I or U with 1, 2, 4, 8 bytes, F "
     r"with 4 or 8\)"),
    (b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH one\nHEIGHT 1\nDATA ascii\n",
     r"malformed PCD header \(COUNT, WIDTH, HEIGHT and POINTS must be integers\)"),
    (b"VERSION .7\nCOLOR red\n", r"malformed PCD header line 2: 'COLOR red'"),
    (b"VERSION .7\nFIELDS x y rgb\nSIZE 4 4 4\nTYPE F F U\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n",
     r"PCD has no z field \(it has: x, y, rgb\)"),
    (b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA lzma\n",
     r"unknown PCD DATA encoding 'lzma' \(ascii, binary or binary_compressed\)"),
    (b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 0\nHEIGHT 1\nPOINTS 0\n"
     b"DATA binary\n", r"the cloud has no points"),
])
def test_bad_pcd(tmp_path, content, problem):
    path = tmp_path / "bad.pcd"
    path.write_bytes(content)
    expect_error(path, problem)


def test_corrupt_compressed_pcd(tmp_path):
    header = (b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\n"
              b"POINTS 2\nDATA binary_compressed\n")
    path = tmp_path / "bad.pcd"
    path.write_bytes(header + np.array([4, 24], "<u4").tobytes() + bytes([0, 1, 0xE0, 9]))
    expect_error(path, r"corrupt PCD \(the compressed data does not decompress\)")
    path.write_bytes(header + np.array([1, 12], "<u4").tobytes() + bytes([0]))
    expect_error(path, r"corrupt PCD \(compressed data holds 12 bytes, the header's points "
                       r"and fields need 24\)")


@pytest.mark.parametrize("content, problem", [
    (b"1 2 3\n4 5\n", r"the file is not numeric x y z text \(invalid column index 2 at row 2 "
                      r"with 2 columns\)"),
    (b"x y z\n1 2 3\n", r"the file is not numeric x y z text \(could not convert string 'x' "
                        r"to float64 at row 0, column 1\.\)"),
    (b"# only a comment\n", r"the cloud has no points"),
    (b"nan nan nan\n1 2 inf\n", r"all 2 points are NaN or infinite"),
])
def test_bad_text(tmp_path, content, problem):
    path = tmp_path / "bad.xyz"
    path.write_bytes(content)
    expect_error(path, problem)


def test_bad_npy(tmp_path):
    path = tmp_path / "bad.npy"
    np.save(path, np.zeros((5, 2)))
    expect_error(path, r"expected an \(N, 3\) or \(N, >=3\) numeric array, got shape \(5, 2\) "
                       r"of float64")
    np.save(path, np.array([{"x": 1}], dtype=object))
    expect_error(path, r"not a readable \.npy array \(.*allow_pickle=False.*\)")
    path.write_bytes(b"plain text, not npy")
    expect_error(path, r"not a readable \.npy array \(.*\)")
    np.save(path, np.zeros((0, 3)))
    expect_error(path, r"the cloud has no points")
