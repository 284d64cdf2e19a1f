"""A simulated Intel RealSense D415: ray-cast a triangle mesh into a 16-bit depth image and
add the sensor's usual artefacts (axial noise, quantisation, holes, flying pixels at depth
edges, random outliers, no return at grazing incidence) and, when asked, the ones our narrow
default leaves out (low-frequency depth ripple, the stereo shadow of the second imager, a
ragged incidence limit). `HIRES` and `SensorNoise.hires()` model a high-resolution
structured-light sensor instead.

Units: metres and radians. Camera frame: OpenCV (x right, y down, z forward).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from weldseam.geometry import transform_points, unit
from weldseam.io.depth import backproject_depth
from weldseam.types import Intrinsics

D415 = Intrinsics(
    width=640, height=480, fx=619.97, fy=619.86, cx=311.23, cy=226.93, depth_scale=1000.0
)
# A 1944x1200 structured-light sensor (61 x 40 deg field of view), 0.1 mm depth units.
HIRES = Intrinsics(
    width=1944, height=1200, fx=1650.0, fy=1650.0, cx=971.5, cy=599.5, depth_scale=10000.0
)


def look_at(eye_m, target_m, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """(4, 4) T_base_camera of a camera at `eye_m` (3,) whose optical axis z points at
    `target_m` (3,). Image x = unit(z x up), image y (down) = z x x, so `up` shows toward the
    top of the image. When `up` is parallel to the optical axis, base y (then base x) is used.
    """
    eye = np.asarray(eye_m, dtype=np.float64)
    forward = np.asarray(target_m, dtype=np.float64) - eye
    if np.linalg.norm(forward) == 0:
        raise ValueError("look_at: eye and target coincide")
    z = unit(forward)
    for candidate in (up, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)):
        x = np.cross(z, np.asarray(candidate, dtype=np.float64))
        if np.linalg.norm(x) > 1e-6:
            break
    x = unit(x)
    matrix = np.eye(4)
    matrix[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    matrix[:3, 3] = eye
    return matrix


@dataclass(frozen=True)
class SensorNoise:
    """The D415's artefacts; set a field to 0 (incidence: 90) to switch that effect off.

    Axial noise: Gaussian along the depth with sigma = z^2 * subpixel_px / (fx * baseline_m)
        (z in m), about 0.48 mm at 0.45 m with the defaults.
    quantisation_m: depth resolution; depth is rounded to a multiple of it (0: off). The
        uint16 output is also rounded to 1 / intrinsics.depth_scale, so a sub-millimetre
        clean render needs intrinsics with a larger depth_scale.
    max_incidence_deg: no return where the angle between the ray and the surface normal
        exceeds this.
    hole_fraction, hole_count: about this fraction of the image is lost in this many blobs.
    flying_pixel_probability, flying_pixel_jump_m: a pixel whose depth differs from a
        4-neighbour by more than the jump takes, with this probability, a depth drawn
        uniformly between its own and that neighbour's.
    outlier_count: random pixels that get a random depth (0.5 to 1.5 x the median depth).
    ripple_amplitude_m: low-frequency depth ripple (the D415's 0.15-0.25 mm "wobble" on a
        flat wall): three plane waves across the image, wavelengths `ripple_wavelength_px`,
        summed and scaled so the largest |ripple| in the image is this (0: off).
    stereo_shadow_side: +1 or -1: the second imager sits `baseline_m` along +x or -x of the
        camera; surfaces it cannot see (the ray from it meets something else first) get no
        depth. 0: off.
    incidence_jitter_deg: the incidence limit varies per pixel with this standard deviation
        (degrees), so the edge of the lost region is ragged, as on real metal.
    """

    subpixel_px: float = 0.08
    baseline_m: float = 0.055
    quantisation_m: float = 0.001
    max_incidence_deg: float = 75.0
    hole_fraction: float = 0.03
    hole_count: int = 5
    flying_pixel_probability: float = 0.5
    flying_pixel_jump_m: float = 0.005
    outlier_count: int = 300
    ripple_amplitude_m: float = 0.0
    ripple_wavelength_px: tuple[float, float] = (60.0, 240.0)
    stereo_shadow_side: int = 0
    incidence_jitter_deg: float = 0.0

    @classmethod
    def clean(cls, quantisation_m: float = 0.0) -> SensorNoise:
        """A perfect sensor (only the optional depth quantisation stays)."""
        return cls(
            subpixel_px=0.0, quantisation_m=quantisation_m, max_incidence_deg=90.0,
            hole_fraction=0.0, flying_pixel_probability=0.0, outlier_count=0,
        )

    @classmethod
    def realistic(cls, rng: np.random.Generator) -> SensorNoise:
        """The D415 with what the default leaves out, drawn per scan: ripple 0.15-0.25 mm,
        the stereo shadow on a random side, the incidence limit 70-80 deg with 2 deg jitter."""
        return cls(
            max_incidence_deg=float(rng.uniform(70.0, 80.0)),
            ripple_amplitude_m=float(rng.uniform(0.00015, 0.00025)),
            stereo_shadow_side=int(rng.choice([-1, 1])),
            incidence_jitter_deg=2.0,
        )

    @classmethod
    def hires(cls, rng: np.random.Generator) -> SensorNoise:
        """A high-resolution structured-light sensor (use with `HIRES`): 0.07 mm axial noise
        at 0.45 m (projector 0.1 m from the camera, 0.057 px matching error at fx 1650),
        0.1 mm depth steps, fewer holes and flying pixels, ripple 0.02-0.04 mm, the
        projector's shadow on a random side."""
        return cls(
            subpixel_px=0.057, baseline_m=0.10, quantisation_m=0.0001, hole_fraction=0.01,
            flying_pixel_probability=0.3, outlier_count=300,
            ripple_amplitude_m=float(rng.uniform(0.00002, 0.00004)),
            stereo_shadow_side=int(rng.choice([-1, 1])), incidence_jitter_deg=2.0,
        )

    def axial_sigma_m(self, depth_m: np.ndarray, fx: float) -> np.ndarray:
        """Standard deviation (m) of the depth noise at depth `depth_m` (m)."""
        return depth_m**2 * self.subpixel_px / (fx * self.baseline_m)


def cast_rays(mesh, origins_m: np.ndarray, directions: np.ndarray):
    """Intersect rays with `mesh` (a trimesh.Trimesh) using Open3D's ray caster.

    origins_m, directions: (N, 3); returns t_hit (N,) in units of each direction's length
    (inf where the ray misses) and the hit triangles' unit normals (N, 3), float64.
    """
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(np.asarray(mesh.vertices, dtype=np.float32)),
        o3d.core.Tensor(np.asarray(mesh.faces, dtype=np.uint32)),
    )
    rays = np.hstack([np.broadcast_to(origins_m, directions.shape), directions])
    hits = scene.cast_rays(o3d.core.Tensor(rays.astype(np.float32)))
    return (
        hits["t_hit"].numpy().astype(np.float64),
        hits["primitive_normals"].numpy().astype(np.float64),
    )


def render_depth(
    mesh, T_base_camera: np.ndarray, intrinsics: Intrinsics, rng: np.random.Generator,
    noise: SensorNoise,
) -> np.ndarray:
    """(H, W) uint16 depth image (units of 1 / intrinsics.depth_scale m, 0 = no data) of
    `mesh` (trimesh.Trimesh, base frame) seen by a camera at `T_base_camera` (4, 4)."""
    height, width = intrinsics.height, intrinsics.width
    rows, cols = np.mgrid[0:height, 0:width]
    camera_directions = np.stack(
        [(cols - intrinsics.cx) / intrinsics.fx, (rows - intrinsics.cy) / intrinsics.fy,
         np.ones((height, width))], axis=-1,
    ).reshape(-1, 3)
    directions = camera_directions @ T_base_camera[:3, :3].T
    # Each direction has camera-frame z = 1, so t_hit is the depth z itself.
    t_hit, normals = cast_rays(mesh, T_base_camera[:3, 3], directions)
    cos_incidence = np.abs(np.sum(normals * unit(directions), axis=1)).reshape(height, width)
    depth = np.where(np.isfinite(t_hit), t_hit, 0.0).reshape(height, width)
    shadowed = _stereo_shadow(mesh, T_base_camera, directions, depth, noise)

    depth = _add_flying_pixels(depth, rng, noise)
    depth = depth + rng.standard_normal(depth.shape) * noise.axial_sigma_m(depth, intrinsics.fx)
    if noise.ripple_amplitude_m > 0:
        depth = depth + (depth > 0) * _ripple(depth.shape, rng, noise)
    if noise.quantisation_m > 0:
        depth = np.rint(depth / noise.quantisation_m) * noise.quantisation_m
    limit_deg = _incidence_limit_deg(depth.shape, rng, noise)
    lost = (cos_incidence < np.cos(np.radians(limit_deg))) | _holes(depth.shape, rng, noise)
    depth = np.where(lost | shadowed, 0.0, depth)
    depth = _add_outliers(depth, rng, noise.outlier_count)

    units = np.rint(depth * intrinsics.depth_scale)
    return np.where((units > 0) & (units <= np.iinfo(np.uint16).max), units, 0).astype(np.uint16)


def _stereo_shadow(mesh, T_base_camera, directions, depth, noise: SensorNoise) -> np.ndarray:
    """(H, W) bool: pixels whose surface point the second imager, `baseline_m` along the
    camera's x axis (side `stereo_shadow_side`), cannot see. directions: (H*W, 3) base-frame
    rays with camera-frame z = 1, so point = origin + depth * direction."""
    if noise.stereo_shadow_side == 0:
        return np.zeros(depth.shape, dtype=bool)
    seen = depth.reshape(-1) > 0
    points = T_base_camera[:3, 3] + depth.reshape(-1)[seen, None] * directions[seen]
    second = T_base_camera[:3, 3] + noise.stereo_shadow_side * noise.baseline_m * T_base_camera[:3, 0]
    rays = points - second
    distance = np.linalg.norm(rays, axis=1)
    t_hit, _ = cast_rays(mesh, second, rays / distance[:, None])
    # 0.5 mm: well above the float32 ray caster's error, well below any occluding step.
    shadowed = np.zeros(depth.size, dtype=bool)
    shadowed[seen] = t_hit < distance - 0.0005
    return shadowed.reshape(depth.shape)


def _ripple(shape: tuple[int, int], rng: np.random.Generator, noise: SensorNoise):
    """(H, W) depth ripple (m): three plane waves of random direction, phase and wavelength
    in `ripple_wavelength_px`, summed, scaled to a peak |value| of ripple_amplitude_m."""
    angles = rng.uniform(0.0, np.pi, 3)
    wavelengths = rng.uniform(*noise.ripple_wavelength_px, 3)
    phases = rng.uniform(0.0, 2 * np.pi, 3)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    waves = np.cos(
        2 * np.pi * (cols[None] * np.cos(angles)[:, None, None]
                     + rows[None] * np.sin(angles)[:, None, None]) / wavelengths[:, None, None]
        + phases[:, None, None]
    ).sum(axis=0)
    return noise.ripple_amplitude_m * waves / np.abs(waves).max()


def _incidence_limit_deg(shape: tuple[int, int], rng: np.random.Generator, noise: SensorNoise):
    """The incidence limit (degrees): max_incidence_deg, jittered per pixel when asked."""
    if noise.incidence_jitter_deg <= 0:
        return noise.max_incidence_deg
    return noise.max_incidence_deg + noise.incidence_jitter_deg * rng.standard_normal(shape)


def _add_flying_pixels(depth: np.ndarray, rng: np.random.Generator, noise: SensorNoise):
    """Depth (H, W) with pixels at depth discontinuities moved toward their neighbour."""
    if noise.flying_pixel_probability <= 0:
        return depth
    padded = np.pad(depth, 1)
    neighbours = np.stack(
        [padded[:-2, 1:-1], padded[2:, 1:-1], padded[1:-1, :-2], padded[1:-1, 2:]]
    )
    jumps = np.where((neighbours > 0) & (depth > 0), neighbours - depth, 0.0)
    largest = np.take_along_axis(jumps, np.abs(jumps).argmax(axis=0)[None], axis=0)[0]
    flying = (np.abs(largest) > noise.flying_pixel_jump_m) & (
        rng.random(depth.shape) < noise.flying_pixel_probability
    )
    return depth + flying * rng.random(depth.shape) * largest


def _holes(shape: tuple[int, int], rng: np.random.Generator, noise: SensorNoise) -> np.ndarray:
    """(H, W) bool mask of `hole_count` ragged elliptical blobs covering ~hole_fraction."""
    if noise.hole_fraction <= 0 or noise.hole_count <= 0:
        return np.zeros(shape, dtype=bool)
    from scipy.ndimage import gaussian_filter

    count = noise.hole_count
    areas_px = noise.hole_fraction * shape[0] * shape[1] / count * rng.uniform(0.5, 1.5, count)
    aspect = rng.uniform(1.0, 3.0, count)
    semi_major = np.sqrt(areas_px * aspect / np.pi)[:, None, None]
    semi_minor = np.sqrt(areas_px / (aspect * np.pi))[:, None, None]
    angle = rng.uniform(0.0, np.pi, count)[:, None, None]
    centre_row = rng.uniform(0, shape[0], count)[:, None, None]
    centre_col = rng.uniform(0, shape[1], count)[:, None, None]
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    along = (cols - centre_col) * np.cos(angle) + (rows - centre_row) * np.sin(angle)
    across = (rows - centre_row) * np.cos(angle) - (cols - centre_col) * np.sin(angle)
    radius_sq = (along / semi_major) ** 2 + (across / semi_minor) ** 2
    ragged = gaussian_filter(rng.standard_normal(shape), 3.0)
    ragged *= 0.3 / max(ragged.std(), 1e-12)
    return np.any(radius_sq < 1.0 + ragged, axis=0)


def _add_outliers(depth: np.ndarray, rng: np.random.Generator, count: int) -> np.ndarray:
    """Depth with `count` random pixels set to 0.5 to 1.5 x the median valid depth."""
    valid = depth[depth > 0]
    if count <= 0 or valid.size == 0:
        return depth
    depth = depth.copy()
    pixels = rng.choice(depth.size, size=min(count, depth.size), replace=False)
    depth.flat[pixels] = rng.uniform(0.5, 1.5, len(pixels)) * np.median(valid)
    return depth


def scan_points(depth: np.ndarray, intrinsics: Intrinsics, T_base_camera: np.ndarray):
    """(N, 3) base-frame points (m) of the valid pixels of a depth image."""
    return transform_points(T_base_camera, backproject_depth(depth, intrinsics))
