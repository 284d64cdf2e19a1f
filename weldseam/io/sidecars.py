"""The files beside a scan that say how to read and place it: one rule for `plan` and `batch`.

For a scan `NAME.EXT`: the camera pose is `NAME.pose.json`, else `pose.json` in its folder; a
depth image's intrinsics are `NAME.intrinsics.json`, else `intrinsics.json`, else the only
`*.intrinsics.json` in its folder.
"""

from __future__ import annotations

from pathlib import Path


def sidecars(scan: Path) -> tuple[Path | None, Path | None]:
    """(intrinsics, camera pose) files for `scan` by the convention above, or None."""
    stem = scan.name[: -len(scan.suffix)] if scan.suffix else scan.name
    intrinsics = None
    if scan.suffix.lower() == ".png":
        candidates = [scan.with_name(f"{stem}.intrinsics.json"), scan.with_name("intrinsics.json")]
        intrinsics = next((path for path in candidates if path.is_file()), None)
        if intrinsics is None:
            others = sorted(scan.parent.glob("*.intrinsics.json"))
            intrinsics = others[0] if len(others) == 1 else None
    pose = next((p for p in (scan.with_name(f"{stem}.pose.json"), scan.with_name("pose.json")) if p.is_file()), None)
    return intrinsics, pose


def own_pose_name(scan: str) -> str:
    """The `NAME.pose.json` a scan's own pose is expected in, for messages."""
    path = Path(scan)
    return str(path.with_name(f"{path.name[: -len(path.suffix)] if path.suffix else path.name}.pose.json"))
