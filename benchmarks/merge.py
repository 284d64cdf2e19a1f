"""What planning over several frames adds: the time to merge D415 frames (640 x 480), and the
pose error left in each frame after ICP.

Renders the standing pipe with a ring groove from 4 views (50 deg above the horizontal, about
290k points a frame) and the grooved box from 3 (fixed seeds), with a 2 mm / 1 deg pose error
on every frame but the first, then times, `--repeat` times each, `merge_frames` with the
default [merge] parameters (veil cut, joint ICP, far sides of thin walls, de-duplication).
Wall time and process CPU time (both cores count) are medians; the target is <= 1.0 s wall
for 4 frames on 2 cores.

Per frame it prints the pose error before ICP and what is left after: how far the frame's
pose puts the seam points it saw from the truth (mean, mm: along the seam too, so a pipe
frame's turn about the axis counts), the same measured across the seam only (distance to
the true seam line), the rotation left (deg), and in how many directions the overlaps left
the pose open. With `--foreign DIR` (default ../shared/foreign) it does the same on the
independent multi-view scans there (depth frames and poses from each case's manifest, the
true poses from its truth.json, read here only to score), or says they are absent.

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
from pathlib import Path

import numpy as np
from common import format_table

TARGET_S = 1.0


def own_scenes():
    """(name, frames, camera origins, given poses, true poses, seam points, seen) of the pipe
    (4 views) and the box (3 views); seen: per frame, (S,) bool the seam points it saw."""
    from weldseam.synthetic.multiview import box_groove_views, pipe_ring_views, pose_error, render_views
    from weldseam.synthetic.sensor import scan_points

    pipe = partial(pipe_ring_views, elevation_deg=50.0)  # steeper views see more table: ~290k points a frame
    for name, views, seed in (("pipe_ring", pipe, 0), ("box_groove", box_groove_views, 1)):
        rng = np.random.default_rng(seed)
        scene, cameras = views(rng)
        scans = render_views(scene, cameras, rng)
        poses = [scan.T_base_camera @ (pose_error(rng) if k else np.eye(4)) for k, scan in enumerate(scans)]
        frames = [scan_points(s.depth, s.intrinsics, pose) for s, pose in zip(scans, poses)]
        yield (name, frames, np.array([pose[:3, 3] for pose in poses]), poses, [s.T_base_camera for s in scans],
               scene.seams[0].points_m, [s.visible[0] for s in scans])


def foreign_scenes(folder: Path):
    """The same tuples for each case of `folder`/multiview (all its seam points count as seen)."""
    from weldseam.geometry import transform_points
    from weldseam.io.depth import backproject_depth, read_depth_png, read_intrinsics

    for case in sorted(p for p in (folder / "multiview").iterdir() if (p / "manifest.json").is_file()):
        views = json.loads((case / "manifest.json").read_text())["views"]
        truth = json.loads((case / "truth.json").read_text())
        poses = [np.array(json.loads((case / v["camera_pose"]).read_text())["T_base_camera"]) for v in views]
        frames = [transform_points(pose, backproject_depth(read_depth_png(case / v["depth"]),
                                                           read_intrinsics(case / v["intrinsics"])))
                  for v, pose in zip(views, poses)]
        seam = np.vstack([np.array(s["points"]) for s in truth["seams"]])
        yield (case.name, frames, np.array([pose[:3, 3] for pose in poses]), poses,
               [np.array(t) for t in truth["true_poses"]], seam, [np.ones(len(seam), dtype=bool)] * len(frames))


def measure(scenes, repeat: int) -> list[dict]:

    from scipy.spatial import cKDTree
    from scipy.spatial.transform import Rotation

    from weldseam.config import MergeConfig
    from weldseam.geometry import transform_points
    from weldseam.pipeline.merge import merge_frames

    params = MergeConfig()
    results = []
    for name, frames, origins, poses, true_poses, seam, seen in scenes:
        print(f"merging {name}", file=sys.stderr)
        walls, cpus = [], []
        for _ in range(repeat):
            wall, cpu = time.perf_counter(), time.process_time()
            merged = merge_frames(frames, origins, params)
            walls.append(time.perf_counter() - wall)
            cpus.append(time.process_time() - cpu)
        line = cKDTree(seam)
        views = []
        for k, (given, true) in enumerate(zip(poses, true_poses)):
            error = given @ np.linalg.inv(true)  # where the given pose puts what the true pose puts right
            left = merged.corrections[k] @ error
            points = seam[seen[k]]
            views.append({
                "before_mm": float(np.linalg.norm(transform_points(error, points) - points, axis=1).mean() * 1000),
                "left_mm": float(np.linalg.norm(transform_points(left, points) - points, axis=1).mean() * 1000),
                "left_across_mm": float(line.query(transform_points(left, points))[0].mean() * 1000),
                "left_deg": float(np.degrees(Rotation.from_matrix(left[:3, :3]).magnitude())),
                "open": int(getattr(merged, "undetermined", np.zeros(len(frames), dtype=int))[k]),
            })
        results.append({
            "scene": name, "frames": len(frames), "points": [len(f) for f in frames],
            "merged_points": len(merged.points_m), "wall_s": statistics.median(walls), "max_wall_s": max(walls),
            "cpu_s": statistics.median(cpus), "views": views, "meets": statistics.median(walls) <= TARGET_S,
        })
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3, help="Merges per scene (default: %(default)s).")
    beside = Path(__file__).resolve().parents[1] / ".." / "shared" / "foreign"
    parser.add_argument("--foreign", type=Path, default=beside,
                        help="Folder of the independent scans (default: ../shared/foreign beside the checkout).")
    parser.add_argument("--json", action="store_true", help="Print the results as JSON instead of tables.")
    args = parser.parse_args()
    scenes = list(own_scenes())
    if (args.foreign / "multiview").is_dir():
        scenes += list(foreign_scenes(args.foreign))
    else:
        print(f"{args.foreign / 'multiview'}: absent, only our own scenes are merged", file=sys.stderr)
    results = measure(scenes, args.repeat)
    if args.json:
        print(json.dumps(results, indent=2))
        return
    print(format_table(
        ["scene", "frames", "pts/frame", "merged", "wall s", "max s", "cpu s", "meets"],
        [[r["scene"], str(r["frames"]), f"{sum(r['points']) / r['frames'] / 1000:.0f}k",
          f"{r['merged_points'] / 1000:.0f}k", f"{r['wall_s']:.2f}", f"{r['max_wall_s']:.2f}", f"{r['cpu_s']:.2f}",
          "yes" if r["meets"] else "NO"] for r in results],
    ))
    print()
    print(format_table(
        ["scene", "frame", "before mm", "left mm", "left across mm", "left deg", "open"],
        [[r["scene"], str(k), f"{v['before_mm']:.2f}", f"{v['left_mm']:.2f}", f"{v['left_across_mm']:.2f}",
          f"{v['left_deg']:.3f}", str(v["open"])] for r in results for k, v in enumerate(r["views"]) if k],
    ))


if __name__ == "__main__":
    main()
