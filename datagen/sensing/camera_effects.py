"""Camera effects on a rendered colour image: what a real camera adds between the scene and the
stored pixels. :func:`draw_camera_effects` draws a view's values (plain JSON, stored in the
view's metadata under ``camera_effects``); :func:`apply_camera_effects` applies them and depends
on nothing else, so a stored sample's image is made again from its metadata.

Order, as in a camera: optics first (vignetting, motion and defocus blur), then the sensor
(shot noise, variance proportional to the linear intensity, plus Gaussian read noise: the usual
heteroscedastic Gaussian stand-in for Poisson + read noise; Gaussian draws quantised to 256
levels, see ``NORMAL_FROM_BYTE``), then the image pipeline (exposure and
white-balance gains, gamma, JPEG). Lens distortion (:mod:`datagen.sensing.lens`) is geometric
and is applied before all of them by the caller, to the annotations too. Work is float32 in
linear intensity; sRGB <-> linear by look-up tables.
"""

from __future__ import annotations

import functools
from statistics import NormalDist
from typing import Any

import cv2
import numpy as np

from datagen.config.appearance import CameraEffectsConfig

_ENCODE_LEVELS = 4096  # linear intensity is quantised to 12 bits before the sRGB encoding


def _srgb_to_linear(x: np.ndarray) -> np.ndarray:
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def _linear_to_srgb(x: np.ndarray) -> np.ndarray:
    return np.where(x <= 0.0031308, x * 12.92, 1.055 * np.power(x, 1 / 2.4) - 0.055)


LINEAR_FROM_BYTE = _srgb_to_linear(np.arange(256) / 255.0).astype(np.float32)
# the standard normal at its 256 quantiles (tails cut at 2.9 sigma), scaled to std 1: a random
# byte through this table is a Gaussian draw for image noise at a tenth of the cost of
# Generator.standard_normal (0.7 ms instead of 9 ms for 640x480x3)
_QUANTILES = np.array([NormalDist().inv_cdf((k + 0.5) / 256) for k in range(256)])
NORMAL_FROM_BYTE = (_QUANTILES / _QUANTILES.std()).astype(np.float32)


def normal_image(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """float32 noise of mean 0 and std 1, one draw per element (``shape``: (H, W[, 3]))."""
    data = np.frombuffer(rng.bytes(int(np.prod(shape))), np.uint8).reshape(shape)
    return cv2.LUT(data, NORMAL_FROM_BYTE)


@functools.lru_cache(maxsize=16)
def _encoding_table(gamma: float) -> np.ndarray:
    """(4096,) uint8: quantised linear intensity -> stored byte, with the gamma exponent."""
    encoded = _linear_to_srgb(np.linspace(0.0, 1.0, _ENCODE_LEVELS)) ** gamma
    return np.clip(np.rint(encoded * 255.0), 0, 255).astype(np.uint8)


@functools.lru_cache(maxsize=8)
def _vignetting_map(width: int, height: int, strength: float) -> np.ndarray:
    """(H, W, 3) float32 gain: 1 at the centre, 1 - strength at the corners (quadratic in r)."""
    cols = (np.arange(width, dtype=np.float32) + 0.5 - width / 2) / (width / 2)
    rows = (np.arange(height, dtype=np.float32) + 0.5 - height / 2) / (height / 2)
    r2 = (cols[None, :] ** 2 + rows[:, None] ** 2) / 2  # 1 at the corners
    return np.repeat((1.0 - strength * r2)[..., None], 3, axis=2).astype(np.float32)


def motion_kernel(length_px: float, angle_deg: float) -> np.ndarray:
    """A line of ``length_px`` pixels at ``angle_deg`` (image x axis, counter-clockwise), sum 1."""
    size = int(np.ceil(length_px)) | 1
    kernel = np.zeros((size, size), np.float32)
    centre, half = size // 2, length_px / 2
    dx, dy = np.cos(np.deg2rad(angle_deg)), -np.sin(np.deg2rad(angle_deg))
    for t in np.linspace(-half, half, 4 * size):
        kernel[round(centre + t * dy), round(centre + t * dx)] += 1.0
    return kernel / kernel.sum()


def disc_kernel(radius_px: float) -> np.ndarray:
    """A disc of ``radius_px`` pixels (edge pixels weighted by coverage, 4x4 supersampled), sum 1."""
    size = 2 * int(np.ceil(radius_px)) + 1
    offsets = (np.arange(size * 4) + 0.5) / 4 - size / 2
    inside = (offsets[None, :] ** 2 + offsets[:, None] ** 2) <= radius_px**2
    kernel = inside.reshape(size, 4, size, 4).mean(axis=(1, 3)).astype(np.float32)
    return kernel / kernel.sum()


def _r(value: float) -> float:
    return round(float(value), 6)


def draw_camera_effects(rng: np.random.Generator, cfg: CameraEffectsConfig) -> dict[str, Any]:
    """One view's effects; an effect that is not applied is absent. Every value is drawn in a
    fixed order whether or not it is used, so changing one probability never moves another
    effect's values. ``distortion`` is [k1, k2, p1, p2, k3] (goes into the calibration)."""
    effects: dict[str, Any] = {}

    def chance(probability: float) -> bool:
        return bool(rng.uniform() < probability)

    on, value = chance(cfg.exposure_probability), rng.uniform(*cfg.exposure_ev)
    if on:
        effects["exposure_ev"] = _r(value)
    on, red, blue = chance(cfg.white_balance_probability), *rng.uniform(*cfg.white_balance, 2)
    if on:
        effects["white_balance"] = [_r(red), 1.0, _r(blue)]
    on, value = chance(cfg.gamma_probability), rng.uniform(*cfg.gamma)
    if on:
        effects["gamma"] = _r(value)
    on, length, angle = (
        chance(cfg.motion_blur_probability),
        rng.uniform(*cfg.motion_blur_px),
        rng.uniform(0, 180),
    )
    if on:
        effects["motion_blur"] = {"length_px": _r(length), "angle_deg": _r(angle)}
    on, value = chance(cfg.defocus_blur_probability), rng.uniform(*cfg.defocus_radius_px)
    if on:
        effects["defocus_blur"] = {"radius_px": _r(value)}
    on, shot, read = (
        chance(cfg.noise_probability),
        rng.uniform(*cfg.shot_noise),
        rng.uniform(*cfg.read_noise),
    )
    noise_seed = int(rng.integers(2**31))
    if on:
        effects["noise"] = {"shot": _r(shot), "read": _r(read), "seed": noise_seed}
    on, value = chance(cfg.vignetting_probability), rng.uniform(*cfg.vignetting)
    if on:
        effects["vignetting"] = _r(value)
    on, quality = (
        chance(cfg.jpeg_probability),
        rng.integers(cfg.jpeg_quality[0], cfg.jpeg_quality[1] + 1),
    )
    if on:
        effects["jpeg_quality"] = int(quality)
    on = chance(cfg.distortion_probability)
    k1, k2, k3 = (
        rng.uniform(*r) for r in (cfg.distortion_k1, cfg.distortion_k2, cfg.distortion_k3)
    )
    p1, p2 = rng.uniform(*cfg.distortion_p, 2)
    if on:
        effects["distortion"] = [_r(k1), _r(k2), _r(p1), _r(p2), _r(k3)]
    return effects


def apply_camera_effects(rgb: np.ndarray, effects: dict[str, Any]) -> np.ndarray:
    """(H, W, 3) uint8 RGB -> the same with ``effects`` (``distortion`` is not applied here)."""
    photometric = set(effects) - {"jpeg_quality", "distortion"}
    out = _photometric(rgb, effects) if photometric else rgb
    if "jpeg_quality" in effects:
        out = jpeg_round_trip(out, effects["jpeg_quality"])
    return out


def _photometric(rgb: np.ndarray, effects: dict[str, Any]) -> np.ndarray:
    height, width = rgb.shape[:2]
    linear = cv2.LUT(rgb, LINEAR_FROM_BYTE)  # (H, W, 3) float32
    if "vignetting" in effects:
        linear = cv2.multiply(linear, _vignetting_map(width, height, float(effects["vignetting"])))
    if "motion_blur" in effects:
        blur = effects["motion_blur"]
        kernel = motion_kernel(blur["length_px"], blur["angle_deg"])
        linear = cv2.filter2D(linear, -1, kernel, borderType=cv2.BORDER_REFLECT)
    if "defocus_blur" in effects:
        kernel = disc_kernel(effects["defocus_blur"]["radius_px"])
        linear = cv2.filter2D(linear, -1, kernel, borderType=cv2.BORDER_REFLECT)
    if "noise" in effects:
        noise = effects["noise"]
        normal = normal_image(np.random.default_rng(noise["seed"]), linear.shape)
        # std = sqrt(shot * I + read^2): shot noise grows with the signal, read noise does not
        std = cv2.sqrt(linear * np.float32(noise["shot"]) + np.float32(noise["read"] ** 2))
        linear += std * normal
    gain = 2.0 ** effects.get("exposure_ev", 0.0) * (_ENCODE_LEVELS - 1)
    channel_gains = [gain * c for c in effects.get("white_balance", [1.0, 1.0, 1.0])]
    linear = cv2.multiply(linear, (*channel_gains, 0.0))  # per channel, as OpenCV scalars are
    np.clip(linear, 0, _ENCODE_LEVELS - 1, out=linear)
    levels = (linear + np.float32(0.5)).astype(np.uint16)
    return np.take(_encoding_table(float(effects.get("gamma", 1.0))), levels)


def jpeg_round_trip(rgb: np.ndarray, quality: int) -> np.ndarray:
    bgr = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
    ok, encoded = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError(f"JPEG encoding failed for an image of shape {rgb.shape}")
    return cv2.cvtColor(cv2.imdecode(encoded, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
