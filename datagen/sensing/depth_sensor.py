"""A structured-light / active-stereo depth sensor made from the clean metric depth: what a
Kinect- or RealSense-like camera at the colour camera would read. ``depth.png`` stays the clean
depth; this makes ``depth_sensor.png`` (uint16 millimetres, 0 = no reading).

Model, in order (values per view, drawn by :func:`draw_depth_sensor`, stored in the view's
metadata under ``depth_sensor``; :func:`sensor_depth` depends on them and the view's images only):

1. noise: z + N(0, a + b z^2) metres (axial noise grows with the square of the distance);
2. quantisation: the disparity d = f B / z (pixels; f the focal length, B = |baseline|) is
   rounded to multiples of ``disparity_step``, so depth steps grow as z^2 step / (f B);
3. holes (no reading) at depth edges (a neighbour's depth differs by more than ``edge_jump`` x
   z, widened by ``edge_width_px``), on dark surfaces (linear luminance of the rendered colour
   below ``dark_threshold``, each such pixel with chance ``dark_dropout``), on specular objects
   (instances listed in ``specular_instances``, chance ``specular_dropout``), and in the
   projector's shadow: pixels that the projector, displaced by ``baseline`` metres along the
   camera's +x, cannot see (a nearer surface covers them in the projector's image). With B > 0
   the shadows lie left of foreground objects, with B < 0 right of them.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from datagen.config.appearance import DepthSensorConfig
from datagen.scene_values.material import Material
from datagen.sensing.camera_effects import LINEAR_FROM_BYTE, normal_image

_SHADOW_TOLERANCE_PX = 0.3  # projector columns closer than this do not occlude (depth rounding)
_LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)  # linear RGB -> luminance


def _r(value: float) -> float:
    return round(float(value), 6)


def draw_depth_sensor(
    rng: np.random.Generator, cfg: DepthSensorConfig, specular_instances: list[int]
) -> dict[str, Any]:
    """One view's sensor values (plain JSON). ``specular_instances``: the instance ids whose
    material passes the config's metallic / roughness test."""
    a, b = rng.uniform(*cfg.noise_a), rng.uniform(*cfg.noise_b)
    baseline, step = rng.uniform(*cfg.baseline), rng.uniform(*cfg.disparity_step)
    edge_jump = rng.uniform(*cfg.edge_jump)
    edge_width = int(rng.integers(cfg.edge_width_px[0], cfg.edge_width_px[1] + 1))
    dark_threshold, dark_dropout = rng.uniform(*cfg.dark_threshold), rng.uniform(*cfg.dark_dropout)
    specular_dropout = rng.uniform(*cfg.specular_dropout)
    return {
        "noise_a": _r(a),
        "noise_b": _r(b),
        "baseline": _r(baseline),
        "disparity_step": _r(step),
        "edge_jump": _r(edge_jump),
        "edge_width_px": edge_width,
        "dark_threshold": _r(dark_threshold),
        "dark_dropout": _r(dark_dropout),
        "specular_instances": sorted(int(i) for i in specular_instances),
        "specular_dropout": _r(specular_dropout),
        "seed": int(rng.integers(2**31)),
    }


def specular(material: Material, cfg: DepthSensorConfig) -> bool:
    """Whether a depth sensor cannot read ``material``: metallic and smooth enough."""
    return (
        material.metallic >= cfg.specular_metallic and material.roughness <= cfg.specular_roughness
    )


def noisy_depth(z: np.ndarray, a: float, b: float, rng: np.random.Generator) -> np.ndarray:
    """(H, W) float32 metres -> with noise of std a + b z^2 (0 stays 0)."""
    std = np.float32(a) + np.float32(b) * z * z
    return np.where(z > 0, z + std * normal_image(rng, z.shape), 0).astype(np.float32)


def quantised(z: np.ndarray, focal_px: float, baseline: float, step: float) -> np.ndarray:
    """Depth whose disparity f |B| / z is rounded to multiples of ``step`` pixels."""
    if step <= 0 or baseline == 0:
        return z
    fb = np.float32(focal_px * abs(baseline))
    with np.errstate(divide="ignore", invalid="ignore"):
        levels = np.rint(fb / (z * np.float32(step)))
        out = fb / (levels * np.float32(step))
    return np.where((z > 0) & (levels > 0), out, 0).astype(np.float32)


def edge_holes(z: np.ndarray, jump: float, width_px: int) -> np.ndarray:
    """(H, W) bool: pixels beside a depth discontinuity (relative jump > ``jump``)."""
    if width_px <= 0:
        return np.zeros(z.shape, bool)
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    farthest = cv2.dilate(z, cross)  # of the pixel and its 4 neighbours
    nearest = cv2.erode(np.where(z > 0, z, np.float32(np.inf)), cross)  # no surface: no edge
    # a neighbour farther than z (1 + jump), or nearer than z / (1 + jump): jump x the nearer
    ratio = np.float32(1 + jump)
    with np.errstate(over="ignore"):  # OpenCV's border value is FLT_MAX: x ratio gives inf
        edges = (farthest > z * ratio) | (nearest * ratio < z)
    edges &= z > 0
    if width_px > 1:
        kernel = np.ones((2 * width_px - 1, 2 * width_px - 1), np.uint8)
        edges = cv2.dilate(edges.view(np.uint8), kernel).astype(bool)
    return edges


def shadow_holes(z: np.ndarray, focal_px: float, baseline: float) -> np.ndarray:
    """(H, W) bool: pixels the projector at +``baseline`` metres along x cannot see. Each row is
    an epipolar line: a point at column u shows at column u - f B / z in the projector, and it is
    hidden when a point on the far side (right for B > 0) lands at or before it."""
    if baseline == 0:
        return np.zeros(z.shape, bool)
    fb = np.float32(focal_px * baseline)
    cols = np.arange(z.shape[1], dtype=np.float32)[None, :]
    with np.errstate(divide="ignore"):
        shift = np.where(z > 0, fb / z, 0).astype(np.float32)
    projector = cols - shift
    if baseline > 0:
        # the smallest projector column among the pixels to the right of each pixel
        empty = np.where(z > 0, projector, np.inf)
        nearest_right = np.minimum.accumulate(empty[:, ::-1], axis=1)[:, ::-1]
        beyond = np.concatenate([nearest_right[:, 1:], np.full((z.shape[0], 1), np.inf)], 1)
        hidden = beyond < projector - _SHADOW_TOLERANCE_PX
    else:
        empty = np.where(z > 0, projector, -np.inf)
        largest_left = np.maximum.accumulate(empty, axis=1)
        before = np.concatenate([np.full((z.shape[0], 1), -np.inf), largest_left[:, :-1]], 1)
        hidden = before > projector + _SHADOW_TOLERANCE_PX
    return hidden & (z > 0)


def dark_pixels(rgb: np.ndarray, threshold: float) -> np.ndarray:
    luminance = cv2.transform(cv2.LUT(rgb, LINEAR_FROM_BYTE), _LUMA[None, :])
    return (
        luminance[..., 0] < np.float32(threshold)
        if luminance.ndim == 3
        else luminance < np.float32(threshold)
    )


def sensor_depth(
    depth_mm: np.ndarray,
    rgb: np.ndarray,
    instance: np.ndarray,
    intrinsics: np.ndarray,
    values: dict[str, Any],
    depth_scale: float = 0.001,
) -> np.ndarray:
    """Clean depth (H, W) uint16 + the view's colour and instance map (the pinhole render's)
    -> sensor depth (H, W) uint16 in the same units, 0 = no reading."""
    rng = np.random.default_rng(values["seed"])
    focal = float(intrinsics[0, 0])
    clean = depth_mm.astype(np.float32) * np.float32(depth_scale)
    z = noisy_depth(clean, values["noise_a"], values["noise_b"], rng)
    z = quantised(z, focal, values["baseline"], values["disparity_step"])
    holes = edge_holes(clean, values["edge_jump"], values["edge_width_px"])
    holes |= shadow_holes(clean, focal, values["baseline"])
    # one uniform draw per pixel, in steps of 1/256, for the dark and specular dropouts
    chance = np.frombuffer(rng.bytes(clean.size), np.uint8).reshape(clean.shape)
    chance = (chance.astype(np.float32) + np.float32(0.5)) / np.float32(256)
    holes |= dark_pixels(rgb, values["dark_threshold"]) & (chance < values["dark_dropout"])
    if values["specular_instances"]:
        shiny = np.isin(instance, values["specular_instances"])
        holes |= shiny & (chance < values["specular_dropout"])
    units = np.rint(z / np.float32(depth_scale))
    units[holes | (clean <= 0)] = 0
    return np.clip(units, 0, np.iinfo(np.uint16).max).astype(np.uint16)
