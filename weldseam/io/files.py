"""Reading an input file, with one clear line when it cannot be read."""

from __future__ import annotations

import json
from pathlib import Path

from weldseam.errors import InputError


def read_input(path: str | Path, kind: str) -> bytes:
    """The whole file; InputError naming it otherwise. `kind` says what the file should
    be ("a point cloud file"), for the message about a directory in its place."""
    try:
        return Path(path).read_bytes()
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, not {kind}") from None
    except OSError as error:
        raise InputError(f"{path}: cannot read ({error.strerror or error})") from None


def read_json(path: str | Path, kind: str):
    """The parsed JSON of a small input file (UTF-8, a BOM allowed)."""
    data = read_input(path, kind)
    try:
        return json.loads(data.decode("utf-8-sig"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise InputError(f"{path}: not valid JSON ({error})") from None
