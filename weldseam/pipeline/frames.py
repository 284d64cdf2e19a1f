"""Several frames of one workpiece: merged (merge.py), then planned as one scan (run.py)."""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from weldseam.config import PlanConfig
from weldseam.errors import InputError
from weldseam.geometry import transform_points
from weldseam.pipeline.merge import merge_frames, merge_warnings
from weldseam.pipeline.run import Dump, plan_paths, timed_step
from weldseam.types import RunResult, Scan


def merged_scan(frames: Sequence[Scan], config: PlanConfig, *, source: str) -> tuple[Scan, object]:
    """(the merged Scan, the merge's result) of several frames of one workpiece, each in the base
    frame with its (3,) camera origin (merge.merge_frames)."""
    if any(frame.camera_origin_m is None for frame in frames):
        raise InputError(f"{source}: every frame needs its pose to be merged with the others")
    merged = merge_frames([frame.points_m for frame in frames], np.array([frame.camera_origin_m for frame in frames]),
                          config.merge)
    digest = hashlib.sha256("".join(frame.sha256 for frame in frames).encode()).hexdigest()
    return Scan(points_m=merged.points_m, camera_origin_m=merged.camera_origins_m, source=source, sha256=digest), merged


def plan_frames(
    frames: Sequence[Scan],
    config: PlanConfig,
    *,
    source: str,
    dump: Dump | None = None,
    on_stage: Callable[[str], None] | None = None,
    allow_empty: bool = False,
) -> RunResult:
    """Merge several frames of one workpiece (each in the base frame with its (3,) camera
    origin) with `merge_frames`, then run `plan_paths` on the merged cloud. The record's
    input lists the frames with the ICP correction of each (how far it moved the frame's
    centroid, mm, and its rotation, degrees), whether it was refined and how many degrees of
    freedom its overlaps left open; `source` names the whole (the manifest, or the scans)."""
    from scipy.spatial.transform import Rotation

    m = config.merge
    spent: dict[str, float] = {}
    with timed_step("merge", spent, on_stage):
        scan, merged = merged_scan(frames, config, source=source)
    if dump is not None:
        dump("merge", merged.points_m, merged.frame.astype(np.float64))
    result = plan_paths(scan, config, dump=dump, on_stage=on_stage, allow_empty=allow_empty)
    warnings = merge_warnings(merged, [frame.source for frame in frames], min_overlap=m.min_overlap, refine=m.refine)
    frames_record = [
        {
            "path": frame.source, "sha256": frame.sha256, "points": len(frame.points_m),
            "kept_points": int((merged.frame == k).sum()),
            "icp_shift_mm": round(float(np.linalg.norm(transform_points(correction, centre) - centre)) * 1000, 6),
            "icp_rotation_deg": round(float(np.degrees(Rotation.from_matrix(correction[:3, :3]).magnitude())), 6),
            "icp_refined": bool(merged.refined[k]), "icp_open_dof": int(merged.undetermined[k]),
            "far_side_points": int(merged.far_side[k]),
        }
        for k, (frame, correction) in enumerate(zip(frames, merged.corrections))
        for centre in [np.nanmean(frame.points_m, axis=0, keepdims=True)]
    ]
    record = {**result.record, "input": {**result.record["input"], "frames": frames_record,
                                         "icp_converged": bool(merged.converged)}}
    timings = {"merge": spent["merge"] + result.timings_s.get("merge", 0.0)}
    timings.update((name, value) for name, value in result.timings_s.items() if name != "merge")
    return replace(
        result, record=record, timings_s=timings,
        warnings=(*warnings, *result.warnings),
    )
