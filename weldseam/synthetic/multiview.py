"""Workpieces that one view cannot cover, with the camera poses that together see the whole
seam, and pose errors to inject (what an imperfect robot or hand-eye calibration adds).

Units: metres and radians; base frame z up, table top at z = 0 (as in scenes.py).
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import trimesh

from weldseam.geometry import transform_points, unit
from weldseam.io.depth import write_intrinsics
from weldseam.synthetic.scenes import (
    UP,
    SyntheticScan,
    SyntheticScene,
    _circle,
    _draw,
    _draw_groove,
    _groove_section,
    _rotation,
    _scene,
    _seam,
    _swept_solid,
    block_groove,
    make_scan,
)
from weldseam.synthetic.sensor import SensorNoise, look_at

VIEW_DISTANCE_M = 0.4


def box_groove_views(rng: np.random.Generator, *, cone: bool = True) -> tuple[SyntheticScene, list[np.ndarray]]:
    """`block_groove` (random size, yaw) and 3 camera poses (4, 4) T_base_camera, 0.4 m from
    the groove: above the -x face, above the top, above the +x face, all three also looking
    at the +y face. Together they see the whole groove (up one face, over the top, down the
    other). A locating cone (radius 30 mm, 45 deg flanks) stands 30 mm beyond the +y face:
    the faces of the block that two views share are the top and the +y face, a prism along
    x that ICP cannot place along x; the cone, seen by every view, can. Without the cone
    (`cone` False) nothing the views share fixes that slide."""
    yaw = float(rng.uniform(0.0, 360.0))
    scene = block_groove(rng, yaw_deg=yaw)
    turn = _rotation(UP, np.radians(yaw))
    seam = scene.seams[0].points_m
    local = transform_points(np.linalg.inv(turn), seam)
    width, height = np.ptp(local[:, 0]), local[:, 2].max()
    if cone:
        beside = np.abs(transform_points(np.linalg.inv(turn), np.asarray(scene.mesh.vertices))[:, 1])
        locator = trimesh.creation.cone(radius=0.03, height=0.03, sections=64)
        locator.apply_translation([0.0, beside[beside < 0.1].max() + 0.06, 0.0])
        scene = dataclasses.replace(scene, mesh=trimesh.util.concatenate([scene.mesh, locator.apply_transform(turn)]))
    cameras = []
    for side in (-1.0, 0.0, 1.0):
        target = np.array([side * width / 2, 0.0, height * (0.6 if side else 1.0)])
        direction = unit(np.array([0.75 * side, 0.5, 0.6 if side else 1.0]))
        eye, target = transform_points(turn, np.array([target + VIEW_DISTANCE_M * direction, target]))
        cameras.append(look_at(eye, target))
    return scene, cameras


def pipe_ring_views(
    rng: np.random.Generator, *, outer_radius_m=None, wall_m=None, height_m=None, included_angle_deg=None,
    root_gap_m=None, views: int = 4, elevation_deg: float = 30.0,
) -> tuple[SyntheticScene, list[np.ndarray]]:
    """A pipe standing on the table (outer radius 50-80 mm, wall 6-10 mm, 160-220 mm tall)
    with a circumferential V-groove at half its height (depth = wall - 1..2 mm, flat bottom
    0-2 mm): a closed horizontal ring. `views` camera poses 0.4 m from the groove, evenly
    around the pipe (random start), `elevation_deg` above the horizontal; at 30 deg each sees
    about a third of the ring, together all of it. From about 45 deg up each view also sees,
    through the open top, the inside of the far wall at the groove's height: a merge of the
    views holds both faces of the wall there, a few millimetres apart."""
    radius = _draw(rng, outer_radius_m, 0.05, 0.08)
    wall = _draw(rng, wall_m, 0.006, 0.010)
    height = _draw(rng, height_m, 0.16, 0.22)
    depth = float(rng.uniform(wall - 0.002, wall - 0.001))
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.002)
    offsets, heights = _groove_section(height / 2, radius, depth, groove)
    radial = _circle(radius)
    centre = np.array([0.0, 0.0, height / 2])
    pipe = _swept_solid(np.broadcast_to(centre, radial.shape), np.broadcast_to(UP, radial.shape), radial,
                        offsets, heights, radius - wall, closed=True)
    seam = _seam(centre + radius * radial, -radial, "v_groove", closed=True)
    scene = _scene("pipe_ring", [pipe], [seam], centre, 0.0)
    start = rng.uniform(0.0, 2 * np.pi)
    elevation = np.radians(elevation_deg)
    cameras = []
    for azimuth in start + 2 * np.pi * np.arange(views) / views:
        outward = np.array([np.cos(azimuth), np.sin(azimuth), 0.0])
        target = centre + radius * outward
        eye = target + VIEW_DISTANCE_M * (np.cos(elevation) * outward + np.sin(elevation) * UP)
        cameras.append(look_at(eye, target))
    return scene, cameras


def render_views(
    scene: SyntheticScene, cameras: list[np.ndarray], rng: np.random.Generator, noise: SensorNoise = SensorNoise()
) -> list[SyntheticScan]:
    """One SyntheticScan per camera pose, rendered in order with `rng`."""
    return [make_scan(scene, rng, noise, T_base_camera=camera) for camera in cameras]


def seen_by_any(scans: list[SyntheticScan]) -> SyntheticScan:
    """The frames as one SyntheticScan for `metrics.evaluate`: all points, and a truth point
    counts as visible when any frame saw it (pose and depth are the first frame's)."""
    first = scans[0]
    visible = tuple(np.any(masks, axis=0) for masks in zip(*(s.visible for s in scans)))
    return SyntheticScan(
        depth=first.depth, intrinsics=first.intrinsics, T_base_camera=first.T_base_camera,
        points_m=np.vstack([s.points_m for s in scans]), camera_origin_m=first.camera_origin_m, visible=visible,
    )


def pose_error(rng: np.random.Generator, translation_m: float = 0.002, rotation_deg: float = 1.0) -> np.ndarray:
    """(4, 4) rigid error E: a rotation of exactly `rotation_deg` about a random axis and a
    translation of exactly `translation_m` in a random direction. A camera pose T with this
    error is T @ E: the camera itself is off by that much (rotated about its own centre)."""
    axis, direction = unit(rng.standard_normal((2, 3)))
    error = _rotation(axis, np.radians(rotation_deg))
    error[:3, 3] = translation_m * direction
    return error


# An eye-in-hand camera 50 mm out from the flange, turned 90 degrees about the flange axis.
T_FLANGE_CAMERA = np.array([[0.0, -1.0, 0.0, 0.03], [1.0, 0.0, 0.0, -0.06], [0.0, 0.0, 1.0, 0.05], [0, 0, 0, 1]])
SCENES = {"box": box_groove_views, "pipe": pipe_ring_views}


def write_frame_set(folder, scans: list[SyntheticScan], poses: list[np.ndarray]) -> list[Path]:
    """Write the frames as a camera on a robot would deliver them: fK.png (16-bit depth, mm),
    fK.pose.json with the flange pose (UR pose vector) that puts the camera at poses[K] (4, 4)
    through T_FLANGE_CAMERA, intrinsics.json and the hand-eye file H.json. Returns the PNG paths."""
    from PIL import Image
    from scipy.spatial.transform import Rotation


    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    names = []
    for index, (scan, pose) in enumerate(zip(scans, poses, strict=True)):
        names.append(folder / f"f{index}.png")
        Image.fromarray(scan.depth).save(names[-1])
        flange = pose @ np.linalg.inv(T_FLANGE_CAMERA)
        vector = np.r_[flange[:3, 3], Rotation.from_matrix(flange[:3, :3]).as_rotvec()]
        (folder / f"f{index}.pose.json").write_text(json.dumps({"flange_pose": vector.round(12).tolist()}) + "\n")
    write_intrinsics(folder / "intrinsics.json", scans[0].intrinsics)
    hand_eye = {"setup": "eye-in-hand", "T_flange_camera": T_FLANGE_CAMERA.tolist()}
    (folder / "H.json").write_text(json.dumps(hand_eye) + "\n")
    return names


def main(argv: list[str]) -> None:
    """`python -m weldseam.synthetic.multiview DIR [box|pipe] [SEED]`: render a scene's frames into DIR."""
    if not 1 <= len(argv) <= 3 or (len(argv) > 1 and argv[1] not in SCENES):
        sys.exit(main.__doc__)
    rng = np.random.default_rng(int(argv[2]) if len(argv) > 2 else 1)
    scene, cameras = SCENES[argv[1] if len(argv) > 1 else "pipe"](rng)
    scans = render_views(scene, cameras, rng)
    for name in write_frame_set(argv[0], scans, [scan.T_base_camera for scan in scans]):
        print(name)


if __name__ == "__main__":
    main(sys.argv[1:])
