"""What planning over several frames adds: the time to merge 4 D415 frames (640 x 480).

Renders the standing pipe with a ring groove from 4 views (50 deg above the horizontal, about
290k points a frame) and the grooved box from 3 (fixed seeds), with a 2 mm / 1 deg pose error
on every frame but the first, then times, `--repeat` times each: `merge_frames` with the
default [merge] parameters (veil cut, ICP, de-duplication) and the per-point camera lookup
that `plan_paths` adds for a merged cloud. Wall time and process CPU time (both cores count)
are medians; the target is merge + lookup <= 1.0 s wall for 4 frames on 2 cores. Also prints
how far each frame's pose put the seam points it saw from the truth (mean, mm), before ICP
and after.

Example:
    .venv/bin/python benchmarks/merge.py --repeat 5
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from functools import partial

import numpy as np
from common import format_table

TARGET_S = 1.0


def scenes():
    """(name, scene, scans, poses) of the pipe (4 views) and the box (3 views)."""
    from weldseam.synthetic.multiview import box_groove_views, pipe_ring_views, pose_error, render_views

    pipe = partial(pipe_ring_views, elevation_deg=50.0)  # steeper views see more table: ~290k points a frame
    for name, views, seed in (("pipe_ring", pipe, 0), ("box_groove", box_groove_views, 1)):
        rng = np.random.default_rng(seed)
        scene, cameras = views(rng)
        scans = render_views(scene, cameras, rng)
        poses = [scan.T_base_camera @ (pose_error(rng) if k else np.eye(4)) for k, scan in enumerate(scans)]
        yield name, scene, scans, poses


def measure(repeat: int) -> list[dict]:
    from dataclasses import asdict

    from scipy.spatial import cKDTree

    from weldseam.config import MergeConfig
    from weldseam.geometry import transform_points
    from weldseam.pipeline.merge import merge_frames
    from weldseam.pipeline.run import _nearest_origins
    from weldseam.synthetic.sensor import scan_points

    params = asdict(MergeConfig())
    results = []
    for name, scene, scans, poses in scenes():
        print(f"merging {name}", file=sys.stderr)
        frames = [scan_points(s.depth, s.intrinsics, pose) for s, pose in zip(scans, poses)]
        origins = np.array([pose[:3, 3] for pose in poses])
        walls, cpus = [], []
        for _ in range(repeat):
            wall, cpu = time.perf_counter(), time.process_time()
            merged = merge_frames(frames, origins, **params)
            _nearest_origins(merged.points_m, merged.camera_origins_m, merged.points_m[::10])
            walls.append(time.perf_counter() - wall)
            cpus.append(time.process_time() - cpu)
        seam = scene.seams[0].points_m
        truth = cKDTree(seam)
        errors = []
        for k, scan in enumerate(scans):
            wrong = poses[k] @ np.linalg.inv(scan.T_base_camera)
            seen = seam[scan.visible[0]]
            errors.append([float(truth.query(transform_points(m, seen))[0].mean() * 1000)
                           for m in (wrong, merged.corrections[k] @ wrong)])
        results.append({
            "scene": name, "frames": len(frames), "points": [len(f) for f in frames],
            "merged_points": int(len(merged.points_m)), "wall_s": statistics.median(walls), "max_wall_s": max(walls),
            "cpu_s": statistics.median(cpus), "seam_error_mm_before_after": errors,
            "meets": statistics.median(walls) <= TARGET_S,
        })
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3, help="Merges per scene (default: %(default)s).")
    parser.add_argument("--json", action="store_true", help="Print the results as JSON instead of a table.")
    args = parser.parse_args()
    results = measure(args.repeat)
    if args.json:
        print(json.dumps(results, indent=2))
        return
    rows = [
        [r["scene"], str(r["frames"]), f"{sum(r['points']) / r['frames'] / 1000:.0f}k",
         f"{r['merged_points'] / 1000:.0f}k",
         f"{r['wall_s']:.2f}", f"{r['max_wall_s']:.2f}", f"{r['cpu_s']:.2f}",
         " ".join(f"{b:.1f}>{a:.2f}" for b, a in r["seam_error_mm_before_after"][1:]),
         "yes" if r["meets"] else "NO"]
        for r in results
    ]
    print(format_table(
        ["scene", "frames", "pts/frame", "merged", "wall s", "max s", "cpu s", "seam err mm before>after", "meets"],
        rows,
    ))


if __name__ == "__main__":
    main()
