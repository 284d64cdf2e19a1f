"""Atomic file writes: readers see the old file or the whole new one, never a partial one."""

from __future__ import annotations

import os
import secrets
from pathlib import Path

from weldseam.errors import InputError


def atomic_write(path: str | Path, data: bytes) -> None:
    """Write `data` to `path` through a temporary file in the same directory.

    The temporary file is fsynced and then renamed over `path` (os.replace), so a crash or
    an error leaves either the previous file or the complete new one. On any failure the
    temporary file is removed. The new file gets the usual permissions (0o666 minus umask).
    `-` (stdout) is not handled here. Raises InputError when the file cannot be written.
    """
    path = Path(path)
    temp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        descriptor = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError as error:
        raise InputError(f"{path}: cannot write ({error.strerror})") from None
    except BaseException:
        # A signal that came during the call is handled as it returns, the file already made (a
        # batch worker's SIGTERM raises SystemExit): it is removed as on any later failure.
        temp.unlink(missing_ok=True)
        raise
    try:
        with os.fdopen(descriptor, "wb") as file:
            file.write(data)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temp, path)
    except BaseException as error:
        temp.unlink(missing_ok=True)
        if isinstance(error, OSError):
            raise InputError(f"{path}: cannot write ({error.strerror or error})") from None
        raise


def check_writable(path: str | Path) -> None:
    """Raise InputError unless a new file can be written at `path`, by creating and removing
    a temporary file beside it: a missing folder, a file in the folder's place, permissions
    and a read-only file system all show before any work is done. An existing `path` is
    fine (it will be replaced) unless it is a folder."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path}: is a folder, not a file name")
    folder = path.parent
    if not folder.exists():
        raise InputError(f"{path}: the folder {folder} does not exist")
    if not folder.is_dir():
        raise InputError(f"{path}: {folder} is a file, not a folder")
    _probe(folder, path)


def prepare_folder(path: str | Path) -> None:
    """Create the folder `path` (and its parents) if needed and check that files can be written
    in it; InputError naming it otherwise (e.g. a file in its place)."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(f"{path}: is a file, not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f"{path}: cannot create the folder ({error.strerror or error})") from None
    _probe(path, path)


def _probe(folder: Path, name: Path) -> None:
    """Create and remove a temporary file in `folder`; InputError naming `name` when that fails."""
    probe = folder / f".weldseam-probe-{secrets.token_hex(4)}.tmp"
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
    except OSError as error:
        raise InputError(f"{name}: cannot write in {folder} ({error.strerror or error})") from None
    probe.unlink(missing_ok=True)
