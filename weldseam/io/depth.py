"""Depth images: read a 16-bit PNG and its intrinsics, back-project to camera-frame points."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

from weldseam.errors import InputError
from weldseam.io.atomic import atomic_write
from weldseam.io.files import read_json
from weldseam.types import Intrinsics


def read_depth_png(path: str | Path) -> np.ndarray:
    """Read a single-channel 16-bit PNG as a (H, W) uint16 array of raw depth units."""
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    try:
        with Image.open(path) as image:
            mode = image.mode
            if mode not in ("I;16", "I;16B", "I;16L", "I"):
                raise InputError(
                    f"{path}: depth PNG must be 16-bit single-channel, got mode {mode!r}"
                    + (" (8-bit)" if mode in ("L", "P", "RGB", "RGBA", "LA", "1") else "")
                )
            depth = np.asarray(image, dtype=np.int64)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (UnidentifiedImageError, OSError, SyntaxError) as error:
        raise InputError(f"{path}: not a readable PNG ({error})") from None
    if depth.min(initial=0) < 0 or depth.max(initial=0) > 65535:
        raise InputError(f"{path}: depth values outside the 16-bit range")
    return depth.astype(np.uint16)


def read_intrinsics(path: str | Path) -> Intrinsics:
    """Read `{"width","height","fx","fy","cx","cy","depth_scale"}` (RealSense `ppx`/`ppy`
    accepted for cx/cy). depth_scale is depth units per metre: 1000 for 1 mm units."""
    return intrinsics_from_json(read_json(path, "an intrinsics file"), str(path))


def intrinsics_from_json(data, path: str) -> Intrinsics:
    """Intrinsics from a parsed intrinsics object (see read_intrinsics); `path` starts each error."""
    if not isinstance(data, dict):
        raise InputError(f"{path}: intrinsics must be a JSON object")
    data = dict(data)
    for ours, realsense in (("cx", "ppx"), ("cy", "ppy")):
        if ours not in data and realsense in data:
            data[ours] = data[realsense]
    missing = [key for key in ("width", "height", "fx", "fy", "cx", "cy") if key not in data]
    if missing:
        raise InputError(f"{path}: intrinsics lack {', '.join(missing)}")
    try:
        values = {key: float(data[key]) for key in ("width", "height", "fx", "fy", "cx", "cy")}
        depth_scale = float(data.get("depth_scale", 1000.0))
    except (TypeError, ValueError):
        raise InputError(f"{path}: intrinsics values must be numbers") from None
    if not all(np.isfinite(list(values.values()))) or values["fx"] <= 0 or values["fy"] <= 0:
        raise InputError(f"{path}: fx and fy must be positive finite numbers")
    if values["width"] < 1 or values["height"] < 1 or not values["width"].is_integer():
        raise InputError(f"{path}: width and height must be positive integers")
    if not np.isfinite(depth_scale) or depth_scale <= 0:
        raise InputError(f"{path}: depth_scale must be a positive number (units per metre)")
    if depth_scale < 1.0:
        raise InputError(
            f"{path}: depth_scale {depth_scale:g} looks like metres per unit (RealSense's "
            f"convention); weldseam wants units per metre, e.g. {1 / depth_scale:g}"
        )
    return Intrinsics(
        width=int(values["width"]), height=int(values["height"]),
        fx=values["fx"], fy=values["fy"], cx=values["cx"], cy=values["cy"],
        depth_scale=depth_scale,
    )


def write_intrinsics(path: str | Path, intrinsics: Intrinsics) -> None:
    """Write intrinsics in the format read_intrinsics reads (all seven keys, indented JSON), atomically."""
    atomic_write(path, (json.dumps(asdict(intrinsics), indent=2) + "\n").encode())


def backproject_depth(depth: np.ndarray, intrinsics: Intrinsics) -> np.ndarray:
    """Camera-frame points (N, 3) in metres of the valid (non-zero) pixels, row-major order.

    z = d / depth_scale, x = (u - cx) z / fx, y = (v - cy) z / fy.
    """
    if depth.shape != (intrinsics.height, intrinsics.width):
        raise InputError(
            f"depth image is {depth.shape[1]}x{depth.shape[0]} but the intrinsics say "
            f"{intrinsics.width}x{intrinsics.height}"
        )
    rows, cols = np.nonzero(depth)
    z = depth[rows, cols].astype(np.float64) / intrinsics.depth_scale
    x = (cols - intrinsics.cx) * z / intrinsics.fx
    y = (rows - intrinsics.cy) * z / intrinsics.fy
    return np.column_stack([x, y, z])
