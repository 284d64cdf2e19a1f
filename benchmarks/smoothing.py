"""Our smoothing stage against Open3D's point-cloud smoothers: noise removed, edges kept, time.

Seed s of family f is rendered as in accuracy.py; the cloud smoothed is the pipeline's working
cloud (1 mm conditioning, 2.5 mm voxel centroids, isolated points dropped). Every method gets
the same 6 mm neighbourhood and keeps the points' order, so each point is scored against the
true surface (the scene mesh) before and after. Creases are the mesh edges whose faces meet
at more than 20 deg (groove edges and roots, plate edges, inside corners); "crease" points lie
within 3 mm of one, "plane" points farther than 15 mm from all.

Example:
    .venv/bin/python benchmarks/smoothing.py --families v_butt --seeds 3
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import numpy as np
from scipy.spatial import cKDTree

from weldseam.config import PlanConfig
from weldseam.pipeline.condition import condition_points, sparse_points
from weldseam.pipeline.grid import voxel_centroids
from weldseam.pipeline.neighbours import radius_graph, radius_pairs
from weldseam.pipeline.smooth import smooth_points
from weldseam.synthetic.scenes import FAMILIES, make_scan

from common import format_table, selected_families

CONFIG = PlanConfig()
RADIUS_M = CONFIG.smooth.radius_m
MAX_NN = 60  # cap of Open3D's hybrid search; a plane has ~36 working points within 6 mm
SIGMA_S_M = RADIUS_M / 2  # the spatial sigma our bilateral weight uses
SIGMA_R_M = 0.001  # about twice the D415's axial noise at 0.45 m (0.48 mm)
ITERATIONS = 3  # Laplacian and Taubin passes
LAMBDA, MU = 0.5, -0.53  # Open3D's default Laplacian and Taubin steps
CREASE_MIN_DEG = 20.0
CREASE_BAND_M = 0.003
PLANE_MIN_M = 0.015
CREASE_SAMPLE_M = 0.0001
REPEATS = 3
FIGURES = ("ms", "rms_mm", "p95_mm", "crease_rms_mm", "crease_p95_mm", "plane_rms_mm")


def working_cloud(points: np.ndarray) -> np.ndarray:
    """The (N, 3) cloud that `plan_paths` hands to its smooth stage."""
    c = CONFIG.condition
    working = voxel_centroids(condition_points(points, voxel_m=c.voxel_m), c.working_voxel_m)
    pairs = radius_pairs(working, CONFIG.normals.radius_m)
    return working[~sparse_points(pairs, len(working), min_fraction=c.outlier_fraction)]


def smoothers(knn: int) -> dict:
    """Method name -> function (N, 3) -> (N, 3); each builds its own neighbourhoods."""
    import open3d as o3d

    search = o3d.geometry.KDTreeSearchParamHybrid(radius=RADIUS_M, max_nn=MAX_NN)

    def cloud(points):
        return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))

    def bilateral(points):
        # Normals from the same neighbourhood; left to itself Open3D uses its default 30-NN.
        noisy = cloud(points)
        noisy.estimate_normals(search)
        return np.asarray(noisy.smooth_bilateral(search, SIGMA_S_M, SIGMA_R_M).points)

    return {
        "none": lambda p: p,
        "weldseam": lambda p: smooth_points(p, radius_graph(p, RADIUS_M), radius_m=RADIUS_M),
        "o3d bilateral": bilateral,
        "o3d mls": lambda p: np.asarray(cloud(p).smooth_mls(search).points),
        "o3d laplacian": lambda p: np.asarray(cloud(p).smooth_laplacian(ITERATIONS, LAMBDA, knn).points),
        "o3d taubin": lambda p: np.asarray(cloud(p).smooth_taubin(ITERATIONS, LAMBDA, MU, knn).points),
    }


def crease_samples(mesh) -> np.ndarray:
    """Points (K, 3) every CREASE_SAMPLE_M along the mesh edges sharper than CREASE_MIN_DEG."""
    sharp = mesh.face_adjacency_angles > np.radians(CREASE_MIN_DEG)
    start, end = mesh.vertices[mesh.face_adjacency_edges[sharp]].transpose(1, 0, 2)
    counts = np.ceil(np.linalg.norm(end - start, axis=1) / CREASE_SAMPLE_M).astype(int) + 1
    edge = np.repeat(np.arange(len(counts)), counts)
    t = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / (counts[edge] - 1)
    return start[edge] + t[:, None] * (end - start)[edge]


def surface_distance(mesh):
    """Function (N, 3) -> (N,) unsigned distance (m) to the mesh's triangles."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(np.asarray(mesh.vertices, np.float32)), o3d.core.Tensor(np.asarray(mesh.faces, np.uint32))
    )
    return lambda points: scene.compute_distance(o3d.core.Tensor(points.astype(np.float32))).numpy().astype(float)


def _rms_mm(distances: np.ndarray) -> float:
    return float(np.sqrt(np.mean(distances**2)) * 1000) if len(distances) else float("nan")


def _p95_mm(distances: np.ndarray) -> float:
    return float(np.percentile(distances, 95) * 1000) if len(distances) else float("nan")


def measure(family: str, seed: int) -> list[dict]:
    """One record per method for one rendered (family, seed)."""
    rng = np.random.default_rng(seed)
    scene = FAMILIES[family](rng)
    points = working_cloud(make_scan(scene, rng).points_m)
    to_crease, _ = cKDTree(crease_samples(scene.mesh)).query(points, workers=-1)
    crease, plane = to_crease <= CREASE_BAND_M, to_crease > PLANE_MIN_M
    knn = int(np.median(cKDTree(points).query_ball_point(points, RADIUS_M, return_length=True, workers=-1))) - 1
    distance = surface_distance(scene.mesh)
    records = []
    for method, smooth in smoothers(knn).items():
        times = []
        for _ in range(REPEATS):
            start = time.perf_counter()
            smoothed = smooth(points)
            times.append(time.perf_counter() - start)
        if smoothed.shape != points.shape:
            raise RuntimeError(f"{method} returned {smoothed.shape} points for {points.shape}")
        d = distance(smoothed)
        records.append({
            "family": family, "seed": seed, "method": method, "points": len(points), "crease_points": int(crease.sum()),
            "plane_points": int(plane.sum()), "knn": knn, "ms": statistics.median(times) * 1000,
            "rms_mm": _rms_mm(d), "p95_mm": _p95_mm(d), "crease_rms_mm": _rms_mm(d[crease]),
            "crease_p95_mm": _p95_mm(d[crease]), "plane_rms_mm": _rms_mm(d[plane]),
        })
    return records


def summarise(runs: list[dict], family: str) -> dict[str, dict[str, float]]:
    """Method -> median over the family's seeds of each figure (each column on its own)."""
    runs = [r for r in runs if r["family"] == family]
    return {
        method: {key: statistics.median(r[key] for r in runs if r["method"] == method)
                 for key in ("points", "crease_points", "plane_points", *FIGURES)}
        for method in dict.fromkeys(r["method"] for r in runs)
    }


def report(summaries: dict[str, dict], seeds: int) -> str:
    """One table per family: methods as rows, medians over seeds as columns."""
    header = ["method", "ms", "rms mm", "p95 mm", "crease rms", "crease p95", "plane rms"]
    lines = [(
        f"smoothing: median over seeds 0-{seeds - 1}; distances to the true surface (mm); {RADIUS_M * 1000:g} mm "
        f"neighbourhoods; crease = within {CREASE_BAND_M * 1000:g} mm of a mesh edge > {CREASE_MIN_DEG:g} deg, "
        f"plane = beyond {PLANE_MIN_M * 1000:g} mm"
    )]
    for family, summary in summaries.items():
        none = summary["none"]
        lines += [
            "",
            f"{family}: {none['points']:.0f} points, {none['crease_points']:.0f} crease, {none['plane_points']:.0f} plane",
            format_table(header, [
                [method, f"{s['ms']:.0f}", *(f"{s[key]:.3f}" for key in FIGURES[1:])] for method, s in summary.items()
            ]),
        ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--families", default="v_butt,fillet_t", help="Comma-separated families (default: %(default)s).")
    parser.add_argument("--seeds", type=int, default=5, help="Seeds 0 .. N-1 per family (default: %(default)s).")
    parser.add_argument("--json", action="store_true", help="Print the results as JSON instead of tables.")
    args = parser.parse_args()
    families = selected_families(parser, args.families, FAMILIES)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")

    runs = []
    for family in families:
        for seed in range(args.seeds):
            runs += measure(family, seed)
            print(f"{family} seed {seed}: {runs[-1]['points']} points", file=sys.stderr)
    summaries = {family: summarise(runs, family) for family in families}
    if args.json:
        parameters = {
            "radius_m": RADIUS_M, "max_nn": MAX_NN, "sigma_s_m": SIGMA_S_M, "sigma_r_m": SIGMA_R_M,
            "iterations": ITERATIONS, "lambda": LAMBDA, "mu": MU, "crease_min_deg": CREASE_MIN_DEG,
            "crease_band_m": CREASE_BAND_M, "plane_min_m": PLANE_MIN_M, "repeats": REPEATS,
        }
        record = {"seeds": args.seeds, "parameters": parameters, "summaries": summaries, "runs": runs}
        print(json.dumps(record, indent=2))
    else:
        print(report(summaries, args.seeds))


if __name__ == "__main__":
    main()
