"""Regenerate the bundled samples, their ground truth and the golden path files.

    .venv/bin/python samples/make_samples.py     (or: make samples)

Each sample is a synthetic D415-like scan of one workpiece family with a fixed seed:
- v_butt.ply: a point cloud in the base frame (binary PLY, 1 mm voxels), with
  v_butt.pose.json (the camera pose, whose translation orients the normals);
- fillet_t.png: a raw 16-bit depth image (1 mm units) in the camera frame, with
  d415.intrinsics.json and fillet_t.pose.json (T_base_camera);
- <name>.truth.json: the ground-truth seams the camera saw (for tests);
- golden/<name>.json: the path weldseam plans for it (for regression checks);
- ../docs/report.png: the README's picture, v_butt's HTML report as headless chromium shows it
  (left as it is, with a note, when chromium is not installed).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from weldseam.io.clouds import write_ply
from weldseam.io.depth import write_intrinsics
from weldseam.pipeline.grid import voxel_centroids
from weldseam.synthetic.scenes import FAMILIES, make_scan
from weldseam.synthetic.sensor import D415

HERE = Path(__file__).resolve().parent
SEEDS = {"v_butt": 3, "fillet_t": 1}


def write_json(path: Path, data) -> None:
    path.write_text(json.dumps(data, indent=2) + "\n")


def truth_record(scene, scan) -> dict:
    return {
        "seams": [
            {
                "joint": seam.joint,
                "closed": bool(seam.closed),
                "points_m": np.round(seam.points_m[visible], 7).tolist(),
                "torch_axes": np.round(seam.torch_axes[visible], 7).tolist(),
            }
            for seam, visible in zip(scene.seams, scan.visible)
            if visible.any()
        ]
    }


def main() -> None:
    (HERE / "golden").mkdir(exist_ok=True)
    write_intrinsics(HERE / "d415.intrinsics.json", D415)
    commands = {}
    for name, seed in SEEDS.items():
        rng = np.random.default_rng(seed)
        scene = FAMILIES[name](rng)
        scan = make_scan(scene, rng)
        write_json(HERE / f"{name}.pose.json", {"T_base_camera": np.round(scan.T_base_camera, 9).tolist()})
        write_json(HERE / f"{name}.truth.json", truth_record(scene, scan))
        if name == "fillet_t":
            Image.fromarray(scan.depth).save(HERE / f"{name}.png")
            commands[name] = [f"{name}.png", "--intrinsics", "d415.intrinsics.json", "--camera-pose", f"{name}.pose.json"]
        else:
            write_ply(HERE / f"{name}.ply", voxel_centroids(scan.points_m, 0.001))
            commands[name] = [f"{name}.ply", "--camera-pose", f"{name}.pose.json"]
    for name, arguments in commands.items():
        subprocess.run(
            [sys.executable, "-m", "weldseam.cli", "plan", *arguments, "-o", f"golden/{name}.json", "-q"],
            cwd=HERE, check=True,
        )
        print(f"samples/{name}: scan, truth and golden path written")
    write_report_picture(HERE.parent / "docs" / "report.png")


def write_report_picture(target: Path) -> None:
    """The v_butt report page, rendered by headless chromium (network closed) at 1200 x 900."""
    chromium = shutil.which("chromium")
    if chromium is None:
        print(f"{target}: not redrawn (needs chromium: apt-get install chromium)")
        return
    with tempfile.TemporaryDirectory() as work:
        page = Path(work) / "report.html"
        subprocess.run(
            [sys.executable, "-m", "weldseam.cli", "plan", "v_butt.ply", "--camera-pose", "v_butt.pose.json",
             "-o", str(Path(work) / "path.json"), "--report", str(page), "-q"],
            cwd=HERE, check=True,
        )  # fmt: skip
        subprocess.run(
            [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
             "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={work}/profile",
             "--host-resolver-rules=MAP * ~NOTFOUND", "--hide-scrollbars", "--window-size=1200,900",
             "--virtual-time-budget=20000", f"--screenshot={target}", page.as_uri()],
            capture_output=True, check=True,
        )  # fmt: skip
    print(f"{target}: redrawn")


if __name__ == "__main__":
    main()
