"""Point cloud files: read PLY, PCD, XYZ/TXT and NPY scans; write a small debug PLY.

Everything is parsed with numpy (no open3d import) so that reading is fast and every
bad file gives one InputError line of the form "FILE: problem".
"""

from __future__ import annotations

import hashlib
import io
import struct
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

from weldseam.errors import InputError
from weldseam.geometry import finite_rows
from weldseam.io.atomic import atomic_write
from weldseam.io.files import read_input
from weldseam.types import as_points


def read_cloud(path: str | Path, *, stdin: BinaryIO | None = None) -> tuple[np.ndarray, str]:
    """Read a point cloud file.

    path: a .ply, .pcd, .xyz, .txt or .npy file (extension case-insensitive), or "-" for
        a PLY read from `stdin` (default sys.stdin.buffer).
    Returns (points, sha256): (N, 3) float64 x, y, z as stored in the file (non-finite
    points kept; the pipeline drops them) and the hex sha256 of the raw bytes.
    Raises InputError for a missing, unreadable, truncated or malformed file, a cloud
    without points, or one whose points are all NaN or infinite.
    """
    if str(path) == "-":
        name, suffix = "stdin", ".ply"
        data = (stdin or sys.stdin.buffer).read()
    else:
        name, suffix = str(path), Path(path).suffix.lower()
        if suffix not in _PARSERS:
            raise InputError(
                f"{name}: unknown point cloud format {suffix or '(no extension)'!r} "
                f"(supported: {', '.join(SUPPORTED)}, or - for a PLY on stdin)"
            )
        data = read_input(name, "a point cloud file")
    if not data:
        raise InputError(f"{name}: empty input (0 bytes)")
    points = _PARSERS[suffix](data, name)
    if len(points) == 0:
        raise InputError(f"{name}: the cloud has no points")
    if not finite_rows(points).any():
        raise InputError(f"{name}: all {len(points)} points are NaN or infinite")
    return points, hashlib.sha256(data).hexdigest()


def write_ply(
    path: str | Path,
    points: np.ndarray,
    *,
    values: np.ndarray | None = None,
    colors: np.ndarray | None = None,
) -> None:
    """Atomically write a binary little-endian PLY for debug dumps.

    points: (N, 3) metres, stored as float32 x, y, z.
    values: optional (N,) per-point scalar, stored as float32 property `value`.
    colors: optional (N, 3) uchar red, green, blue: integers 0..255, or floats in [0, 1]
        (scaled by 255).
    """
    points = as_points(points)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    columns = {"x": points[:, 0], "y": points[:, 1], "z": points[:, 2]}
    if values is not None:
        values = np.asarray(values, dtype=np.float64)
        if values.shape != (len(points),):
            raise InputError(f"values: expected shape ({len(points)},), got {values.shape}")
        fields.append(("value", "<f4"))
        columns["value"] = values
    if colors is not None:
        colors = np.asarray(colors)
        if colors.shape != points.shape:
            raise InputError(f"colors: expected shape {points.shape}, got {colors.shape}")
        if colors.dtype.kind == "f":
            colors = np.rint(np.clip(colors, 0.0, 1.0) * 255.0)
        elif colors.size and (colors.min() < 0 or colors.max() > 255):
            raise InputError("colors: integer colours must be in 0..255")
        for channel, column in zip(("red", "green", "blue"), colors.T):
            fields.append((channel, "u1"))
            columns[channel] = column
    records = np.empty(len(points), dtype=fields)
    for field, column in columns.items():
        records[field] = column
    type_names = {"<f4": "float", "u1": "uchar"}
    header = "".join(
        ["ply\nformat binary_little_endian 1.0\ncomment written by weldseam\n",
         f"element vertex {len(points)}\n"]
        + [f"property {type_names[kind]} {field}\n" for field, kind in fields]
        + ["end_header\n"]
    )
    atomic_write(path, header.encode("ascii") + records.tobytes())


def _header_lines(data: bytes, name: str, kind: str, last: str):
    """Yield (line_number, words, offset_after_line) for the ASCII header of a PLY or PCD
    file, up to and including the line whose first word is `last`."""
    offset, number = 0, 0
    while True:
        newline = data.find(b"\n", offset)
        if newline < 0:
            raise InputError(f"{name}: malformed {kind} header (no {last} line)")
        number += 1
        try:
            words = data[offset:newline].decode("ascii").split()
        except UnicodeDecodeError:
            raise InputError(
                f"{name}: malformed {kind} header (line {number} is not ASCII text)"
            ) from None
        offset = newline + 1
        yield number, words, offset
        if words and words[0].upper() == last.upper():
            return


def _text_columns(text: bytes, columns: tuple[int, ...], name: str, what: str) -> np.ndarray:
    """(rows, len(columns)) float64 from whitespace-separated text (numpy's C parser)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            return np.loadtxt(
                io.BytesIO(text), dtype=np.float64, usecols=columns, ndmin=2, comments="#"
            )
    except ValueError as error:
        raise InputError(f"{name}: {what} is not numeric x y z text ({error})") from None


# --- PLY -----------------------------------------------------------------------------

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_PLY_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}


@dataclass
class _PlyProperty:
    name: str
    kind: str  # numpy type code without byte order, e.g. "f4"
    count_kind: str | None = None  # set for list properties


@dataclass
class _PlyElement:
    name: str
    count: int
    properties: list[_PlyProperty]


def _parse_ply(data: bytes, name: str) -> np.ndarray:
    """(N, 3) float64 vertex x, y, z of an ascii or binary PLY; other data is skipped."""
    if not data.startswith(b"ply"):
        raise InputError(f"{name}: not a PLY file (it must start with a 'ply' line)")
    file_format, elements, offset = _ply_header(data, name)
    vertex = next((element for element in elements if element.name == "vertex"), None)
    if vertex is None:
        raise InputError(f"{name}: PLY has no vertex element")
    names = [prop.name for prop in vertex.properties]
    missing = [axis for axis in "xyz" if axis not in names]
    if missing:
        raise InputError(
            f"{name}: PLY vertex element has no {', '.join(missing)} property "
            f"(it has: {', '.join(names) or 'none'})"
        )
    axes = [names.index(axis) for axis in "xyz"]
    if any(vertex.properties[index].count_kind for index in axes):
        raise InputError(f"{name}: PLY vertex x, y, z must be scalar properties, not lists")
    if file_format == "ascii":
        return _ply_ascii(data[offset:], elements, vertex, axes, name)
    return _ply_binary(data, offset, elements, vertex, axes, _PLY_FORMATS[file_format], name)


def _ply_header(data: bytes, name: str) -> tuple[str, list[_PlyElement], int]:
    """Parse the header: (format, elements in file order, offset of the body)."""
    file_format, elements = None, []
    for number, words, offset in _header_lines(data, name, "PLY", "end_header"):
        bad = f"{name}: malformed PLY header line {number}: {' '.join(words)!r}"
        keyword = words[0] if words else ""
        if number == 1:
            if words != ["ply"]:
                raise InputError(f"{name}: not a PLY file (it must start with a 'ply' line)")
        elif keyword in ("comment", "obj_info"):
            continue
        elif keyword == "format":
            if len(words) != 3 or words[1] not in _PLY_FORMATS:
                raise InputError(bad + f" (format must be one of {', '.join(_PLY_FORMATS)})")
            file_format = words[1]
        elif keyword == "element":
            if len(words) != 3 or not words[2].isdigit():
                raise InputError(bad + " (expected: element NAME COUNT)")
            elements.append(_PlyElement(words[1], int(words[2]), []))
        elif keyword == "property":
            if not elements:
                raise InputError(bad + " (property before any element)")
            if len(words) == 3 and words[1] in _PLY_TYPES:
                prop = _PlyProperty(words[2], _PLY_TYPES[words[1]])
            elif (len(words) == 5 and words[1] == "list" and words[3] in _PLY_TYPES
                  and _PLY_TYPES.get(words[2], "f")[0] in "iu"):
                prop = _PlyProperty(words[4], _PLY_TYPES[words[3]], _PLY_TYPES[words[2]])
            else:
                raise InputError(bad + " (unknown property type)")
            elements[-1].properties.append(prop)
        elif words != ["end_header"]:
            raise InputError(bad)
    if file_format is None:
        raise InputError(f"{name}: malformed PLY header (no format line)")
    hollow = [element.name for element in elements if element.count and not element.properties]
    if hollow:
        raise InputError(f"{name}: malformed PLY header (element {hollow[0]!r} has no properties)")
    return file_format, elements, offset


def _ply_ascii(body: bytes, elements, vertex, axes, name: str) -> np.ndarray:
    """Vertex x, y, z of an ascii PLY body: one element record per line."""
    if any(prop.count_kind for prop in vertex.properties[: max(axes)]):
        raise InputError(f"{name}: PLY ascii list properties before x, y, z are not supported")
    newlines = np.flatnonzero(np.frombuffer(body, dtype=np.uint8) == ord("\n"))
    line_starts = np.concatenate([[0], newlines + 1])
    line_ends = np.concatenate([newlines, [len(body)]])
    available = len(newlines) + bool(body[line_starts[-1]:].strip())
    promised = sum(element.count for element in elements)
    if available < promised:
        raise InputError(
            f"{name}: truncated PLY (the header promises {promised} data lines, "
            f"the file has {available})"
        )
    first = sum(element.count for element in elements[: elements.index(vertex)])
    if vertex.count == 0:
        return np.empty((0, 3))
    text = body[line_starts[first]: line_ends[first + vertex.count - 1]]
    points = _text_columns(text, tuple(axes), name, "PLY vertex data")
    if len(points) != vertex.count:
        raise InputError(
            f"{name}: malformed PLY (expected {vertex.count} vertex lines, "
            f"found {len(points)} with data)"
        )
    return points


def _ply_binary(data: bytes, offset: int, elements, vertex, axes, order: str, name: str):
    """Vertex x, y, z of a binary PLY; walks every element to check nothing is missing."""
    points = None
    for element in elements:
        chunks, offset = _ply_binary_element(data, offset, element, order, name, element is vertex)
        if element is vertex:
            points = np.concatenate(
                [np.column_stack([chunk[f"p{index}"] for index in axes]) for chunk in chunks]
                or [np.empty((0, 3))]
            ).astype(np.float64)
    return points


def _ply_binary_element(data, offset, element, order, name, keep):
    """The records of one binary element (when `keep`) and the offset just after them.

    Records are structured arrays: field p<i> = property i, n<i> = length of list
    property i. A run of records whose lists have the same lengths (all triangles, say)
    is one fixed-size block: its first 8 records are checked in Python, a longer run is
    extended by numpy in doubling windows. A triangle mesh costs a few numpy calls; a
    mesh alternating triangles and quads about 2 us per face.
    """
    layout, skip = [], 0  # per list: (index, bytes before it, count size, signed, item size)
    for index, prop in enumerate(element.properties):
        if prop.count_kind is None:
            skip += int(prop.kind[1])
        else:
            layout.append((index, skip, int(prop.count_kind[1]), prop.count_kind[0] == "i",
                           int(prop.kind[1])))
            skip = 0
    layout.append((None, skip, 0, False, 0))  # the scalars after the last list
    byteorder = "big" if order == ">" else "little"
    dtypes, chunks, done = {}, [], 0
    while done < element.count:
        lengths, size = _ply_record_at(data, offset, layout, byteorder)
        if offset + size > len(data):
            raise InputError(
                f"{name}: truncated PLY (the data ends in element '{element.name}' at record "
                f"{done} of {element.count})"
            )
        if min(lengths, default=0) < 0:
            raise InputError(f"{name}: corrupt PLY (negative list length in '{element.name}')")
        if lengths not in dtypes:
            dtypes[lengths] = _ply_record_dtype(element, lengths, order)
        remaining = min(element.count - done, (len(data) - offset) // size)
        run = 1 if lengths else remaining
        while run < min(8, remaining) and _ply_record_at(
                data, offset + run * size, layout, byteorder)[0] == lengths:
            run += 1
        if run == 8:
            run = _ply_run_length(data, offset, dtypes[lengths], layout, lengths, remaining)
        if keep:
            chunks.append(np.frombuffer(data, dtype=dtypes[lengths], count=run, offset=offset))
        done += run
        offset += run * size
    return chunks, offset


def _ply_record_at(data, offset, layout, byteorder) -> tuple[tuple[int, ...], int]:
    """(list lengths, record size in bytes) of the binary record starting at `offset`.

    A record cut short by the end of the data gives a size reaching past it."""
    position, lengths = offset, []
    for _, skip, count_size, signed, item_size in layout[:-1]:
        position += skip
        length = int.from_bytes(data[position: position + count_size], byteorder, signed=signed)
        lengths.append(length)
        position += count_size + length * item_size
    return tuple(lengths), position + layout[-1][1] - offset


def _ply_record_dtype(element, lengths, order) -> np.dtype:
    """Packed structured dtype of a record whose list properties have `lengths`."""
    fields, lists = [], iter(lengths)
    for index, prop in enumerate(element.properties):
        if prop.count_kind is None:
            fields.append((f"p{index}", order + prop.kind))
        else:
            fields.append((f"n{index}", order + prop.count_kind))
            fields.append((f"p{index}", order + prop.kind, (next(lists),)))
    return np.dtype(fields)


def _ply_run_length(data, offset, dtype, layout, lengths, remaining) -> int:
    """How many records from `offset` (at most `remaining`) have these list lengths."""
    run, window = 0, 64
    while run < remaining:
        block = np.frombuffer(data, dtype=dtype, count=min(window, remaining - run),
                              offset=offset + run * dtype.itemsize)
        same = np.logical_and.reduce(
            [block[f"n{index}"] == length for (index, *_), length in zip(layout, lengths)]
        )
        if not same.all():
            return run + int(np.argmin(same))
        run += len(block)
        window *= 2
    return run


# --- PCD -----------------------------------------------------------------------------

_PCD_KEYS = ("VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT",
             "POINTS", "DATA")


def _parse_pcd(data: bytes, name: str) -> np.ndarray:
    """(N, 3) float64 x, y, z of an ascii, binary or binary_compressed PCD (v0.7)."""
    header, offset = {}, 0
    for number, words, offset in _header_lines(data, name, "PCD", "DATA"):
        if not words or words[0].startswith("#"):
            continue
        if words[0].upper() not in _PCD_KEYS:
            raise InputError(
                f"{name}: malformed PCD header line {number}: {' '.join(words)!r}"
            )
        header[words[0].upper()] = words[1:]
    fields = header.get("FIELDS", [])
    kinds = _pcd_kinds(header, fields, name)
    try:
        counts = [int(count) for count in header.get("COUNT", ["1"] * len(fields))]
        width, height = int(header["WIDTH"][0]), int(header["HEIGHT"][0])
        n_points = int(header.get("POINTS", [width * height])[0])
    except (KeyError, IndexError, ValueError):
        raise InputError(
            f"{name}: malformed PCD header (COUNT, WIDTH, HEIGHT and POINTS must be integers)"
        ) from None
    if len(counts) != len(fields) or min(counts, default=1) < 1 or n_points < 0:
        raise InputError(
            f"{name}: malformed PCD header (COUNT must give one count >= 1 per field, "
            f"POINTS must not be negative)"
        )
    missing = [axis for axis in "xyz" if axis not in fields]
    if missing:
        raise InputError(
            f"{name}: PCD has no {', '.join(missing)} field (it has: {', '.join(fields)})"
        )
    axes = [fields.index(axis) for axis in "xyz"]
    if any(counts[index] != 1 for index in axes):
        raise InputError(f"{name}: PCD x, y, z fields must have COUNT 1")
    encoding = header["DATA"][0].lower() if header["DATA"] else ""
    if n_points == 0:
        return np.empty((0, 3))
    if encoding == "ascii":
        columns = tuple(int(sum(counts[:index])) for index in axes)
        points = _text_columns(data[offset:], columns, name, "PCD data")
        if len(points) != n_points:
            raise InputError(
                f"{name}: truncated PCD (the header promises {n_points} points, "
                f"the data has {len(points)})"
            )
        return points
    dtypes = [np.dtype((kind, (count,)) if count > 1 else kind)
              for kind, count in zip(kinds, counts)]
    record = np.dtype([(f"f{index}", dtype) for index, dtype in enumerate(dtypes)])
    expected = n_points * record.itemsize
    if encoding == "binary":
        if len(data) - offset < expected:
            raise InputError(
                f"{name}: truncated PCD (the header promises {n_points} points = {expected} "
                f"bytes, only {len(data) - offset} bytes follow)"
            )
        records = np.frombuffer(data, dtype=record, count=n_points, offset=offset)
        return np.column_stack([records[f"f{index}"] for index in axes]).astype(np.float64)
    if encoding == "binary_compressed":
        raw = _pcd_decompress(data, offset, expected, name)
        # Compressed PCD stores the data field by field: all x, then all y, ...
        starts = np.cumsum([0] + [n_points * dtype.itemsize for dtype in dtypes])
        return np.column_stack([
            np.frombuffer(raw, dtype=kinds[index], count=n_points, offset=int(starts[index]))
            for index in axes
        ]).astype(np.float64)
    raise InputError(
        f"{name}: unknown PCD DATA encoding {encoding!r} (ascii, binary or binary_compressed)"
    )


def _pcd_kinds(header: dict, fields: list[str], name: str) -> list[str]:
    """Little-endian numpy type codes of the PCD fields from SIZE and TYPE."""
    sizes, types = header.get("SIZE", []), header.get("TYPE", [])
    if not fields or len(sizes) != len(fields) or len(types) != len(fields):
        raise InputError(
            f"{name}: malformed PCD header (FIELDS, SIZE and TYPE must list the same "
            f"number of entries)"
        )
    kinds = [
        "<" + {"I": "i", "U": "u", "F": "f"}.get(kind.upper(), "?") + size
        for kind, size in zip(types, sizes)
    ]
    valid = {"<i1", "<i2", "<i4", "<i8", "<u1", "<u2", "<u4", "<u8", "<f4", "<f8"}
    bad = [f"{kind}{size}" for kind, size, code in zip(types, sizes, kinds) if code not in valid]
    if bad:
        raise InputError(
            f"{name}: malformed PCD header (unsupported TYPE/SIZE {', '.join(bad)}; "
            f"I or U with 1, 2, 4, 8 bytes, F with 4 or 8)"
        )
    return kinds


def _pcd_decompress(data: bytes, offset: int, expected: int, name: str) -> bytearray:
    """The LZF-decompressed body of a binary_compressed PCD (sizes checked)."""
    if len(data) - offset < 8:
        raise InputError(f"{name}: truncated PCD (no compressed data sizes after DATA)")
    compressed_size, raw_size = struct.unpack_from("<II", data, offset)
    if len(data) - offset - 8 < compressed_size:
        raise InputError(
            f"{name}: truncated PCD (the header promises {compressed_size} compressed "
            f"bytes, only {len(data) - offset - 8} follow)"
        )
    if raw_size != expected:
        raise InputError(
            f"{name}: corrupt PCD (compressed data holds {raw_size} bytes, the header's "
            f"points and fields need {expected})"
        )
    raw = lzf_decompress(data[offset + 8: offset + 8 + compressed_size])
    if len(raw) != raw_size:
        raise InputError(f"{name}: corrupt PCD (the compressed data does not decompress)")
    return raw


def lzf_decompress(data: bytes) -> bytearray:
    """Decompress an LZF stream (liblzf format, as PCL and Open3D write it).

    Each token is a literal run (control < 32: the next control + 1 bytes) or a back
    reference (length = control >> 5, plus one byte if 7, plus 2; distance = ((control &
    31) << 8 | next byte) + 1). One Python step per token with slice copies: about 0.3 s
    per million tokens. Corrupt input gives a short result (the caller checks the size).
    """
    out = bytearray()
    position, end = 0, len(data)
    try:
        while position < end:
            control = data[position]
            if control < 32:
                position += 1
                stop = position + control + 1
                out += data[position:stop]
                position = stop
                continue
            length = (control >> 5) + 2
            if length == 9:
                position += 1
                length += data[position]
            start = len(out) - ((control & 31) << 8) - data[position + 1] - 1
            position += 2
            if start < 0:
                break
            stop = start + length
            if stop <= len(out):
                out += out[start:stop]
            else:  # The reference overlaps what it writes: repeat the pattern.
                pattern = out[start:]
                out += (pattern * (length // len(pattern) + 1))[:length]
    except IndexError:
        pass  # truncated token: the size check reports it
    return out


# --- XYZ / TXT / NPY -----------------------------------------------------------------


def _parse_xyz(data: bytes, name: str) -> np.ndarray:
    """x y z from the first three columns of whitespace- or comma-separated lines."""
    return _text_columns(data.replace(b",", b" "), (0, 1, 2), name, "the file")


def _parse_npy(data: bytes, name: str) -> np.ndarray:
    """The first three columns of an (N, >=3) numeric .npy array."""
    try:
        array = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError) as error:
        raise InputError(f"{name}: not a readable .npy array ({error})") from None
    if (not isinstance(array, np.ndarray) or array.dtype.kind not in "iuf"
            or array.ndim != 2 or array.shape[1] < 3):
        shape = getattr(array, "shape", "?")
        dtype = getattr(array, "dtype", type(array).__name__)
        raise InputError(
            f"{name}: expected an (N, 3) or (N, >=3) numeric array, got shape {shape} "
            f"of {dtype}"
        )
    return np.ascontiguousarray(array[:, :3], dtype=np.float64)


_PARSERS = {
    ".ply": _parse_ply, ".pcd": _parse_pcd, ".xyz": _parse_xyz, ".txt": _parse_xyz,
    ".npy": _parse_npy,
}
SUPPORTED = tuple(_PARSERS)  # the file extensions read_cloud accepts
