"""`send --log`: the actual TCP poses read back during each weld, as .csv or .jsonl.

The file is written when the job ends, but its folder is proven writable when the log is created,
before anything connects: a refusal after the weld would come too late (a cell script that reads
the exit code as "nothing happened" would weld the part twice).
"""

from __future__ import annotations

import json
import os
import secrets
from pathlib import Path

import numpy as np

from weldseam.errors import InputError
from weldseam.io.atomic import atomic_write

FORMATS = (".csv", ".jsonl")
CSV_HEADER = "seam,waypoint,x,y,z,rx,ry,rz"


def _prove_writable(path: Path) -> None:
    """InputError unless a new file can be created beside `path` now (created and removed again)."""
    if path.is_dir():
        raise InputError(f"{path}: is a folder, not a file; nothing was sent")
    probe = path.with_name(f".{path.name}.{secrets.token_hex(4)}.probe")
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
    except OSError as error:
        raise InputError(f"{path}: cannot write ({error.strerror}); nothing was sent") from None
    probe.unlink()


class TcpLog:
    """Rows of (seam id, waypoint, TCP pose (6,) m / rotation vector) for one file; save() writes them atomically."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if self.path.suffix.lower() not in FORMATS:
            raise InputError(f"{self.path}: unknown log format {self.path.suffix or '(no extension)'!r} "
                             "(use .csv or .jsonl); nothing was sent")  # fmt: skip
        _prove_writable(self.path)
        self.rows: list[tuple[int, int, np.ndarray]] = []

    def record(self, seam_id: int, waypoint: int, pose: np.ndarray) -> None:
        self.rows.append((int(seam_id), int(waypoint), np.asarray(pose, dtype=float)))

    def text(self) -> str:
        if self.path.suffix.lower() == ".csv":
            lines = [CSV_HEADER] + [
                ",".join([str(seam_id), str(waypoint)] + [f"{v:.9g}" for v in pose])
                for seam_id, waypoint, pose in self.rows
            ]
            return "\n".join(lines) + "\n"
        return "".join(
            json.dumps({"seam_id": seam_id, "waypoint": waypoint, "pose": pose.tolist()}) + "\n"
            for seam_id, waypoint, pose in self.rows
        )

    def save(self) -> None:
        """Write the file (InputError if that fails now: the weld ran, only its log is lost)."""
        try:
            atomic_write(self.path, self.text().encode())
        except InputError as error:
            raise InputError(f"{error}: the job ran, only its TCP log is lost") from None
