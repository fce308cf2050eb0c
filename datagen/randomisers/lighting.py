"""Lighting randomiser: ambient level, a directional key light and spot fill lights (direction,
colour temperature, intensity, hard or soft shadows). SAPIEN's default shader supports one
shadow-casting directional light, so fill lights are spot lights aimed at the tray; a soft key
light is realised as a cluster of shadowed spot lights (:func:`datagen.worlds.realise.apply_lighting`).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from datagen.config.sections import LightingConfig
from datagen.scene_values.lighting import Light, Lighting
from datagen.scene_values.rounding import uniform

FILL_DISTANCE = (1.0, 1.8)  # metres from the light target
WHITE_K = 6500.0  # kelvin: the black body whose colour is white ([1, 1, 1])

# CIE 1931 2-degree colour-matching functions as sums of piecewise Gaussians: the multi-lobe fit
# of Wyman, Sloan and Shirley, "Simple Analytic Approximations to the CIE XYZ Color Matching
# Functions", JCGT 2(2), 2013. Rows: (weight, mean nm, 1/sigma below the mean, 1/sigma above).
_CMF_LOBES = {
    "x": (
        (1.056, 599.8, 0.0264, 0.0323),
        (0.362, 442.0, 0.0624, 0.0374),
        (-0.065, 501.1, 0.0490, 0.0382),
    ),
    "y": ((0.821, 568.8, 0.0213, 0.0247), (0.286, 530.9, 0.0613, 0.0322)),
    "z": ((1.217, 437.0, 0.0845, 0.0278), (0.681, 459.0, 0.0385, 0.0725)),
}
# CIE XYZ -> linear sRGB (IEC 61966-2-1, D65 white)
_XYZ_TO_SRGB = np.array(
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]]
)
_WAVELENGTHS_NM = np.arange(380.0, 781.0, 5.0)


def _cmf(lobes) -> np.ndarray:
    total = np.zeros_like(_WAVELENGTHS_NM)
    for weight, mean, below, above in lobes:
        t = (_WAVELENGTHS_NM - mean) * np.where(mean > _WAVELENGTHS_NM, below, above)
        total += weight * np.exp(-0.5 * t * t)
    return total


_CMF = np.stack([_cmf(_CMF_LOBES[axis]) for axis in "xyz"])  # (3, wavelengths)


def _black_body_srgb(kelvin: float) -> np.ndarray:
    """Linear sRGB of a black body (Planck's law over 380-780 nm against the CMF fit), unscaled."""
    metres = _WAVELENGTHS_NM * 1e-9
    c2 = 1.4387769e-2  # metre-kelvin: h c / k
    radiance = metres**-5 / np.expm1(c2 / (metres * kelvin))
    return _XYZ_TO_SRGB @ (_CMF @ radiance)


def kelvin_to_rgb(kelvin: float) -> np.ndarray:
    """A black body's linear sRGB colour white-balanced so ``WHITE_K`` gives [1, 1, 1], scaled so
    its largest channel is 1 (channels clipped at 0 below ~1500 K, outside the sRGB gamut)."""
    rgb = np.clip(_black_body_srgb(kelvin) / _black_body_srgb(WHITE_K), 0.0, None)
    return rgb / rgb.max()


def light_direction(rng: np.random.Generator, cfg: LightingConfig) -> np.ndarray:
    """Unit vector the light travels along: downwards from a random azimuth and elevation."""
    azimuth = rng.uniform(0, 2 * np.pi)
    elevation = np.deg2rad(rng.uniform(*cfg.elevation_deg))
    return -np.array(
        [
            np.cos(elevation) * np.cos(azimuth),
            np.cos(elevation) * np.sin(azimuth),
            np.sin(elevation),
        ]
    )


def light_colour(rng: np.random.Generator, cfg: LightingConfig) -> tuple[list[float], float]:
    """A light's colour (largest channel 1): a black body at a temperature drawn from
    ``colour_temperature_k`` times a per-channel tint of up to ``colour_temperature_jitter``;
    and the temperature in kelvin. A one-value range draws nothing, so [6500, 6500] draws what
    the lights drew before temperatures existed (``configs/grasp_flat.yaml`` keeps its bytes)."""
    lo, hi = cfg.colour_temperature_k
    kelvin = float(rng.uniform(lo, hi)) if hi > lo else float(lo)
    tint = 1.0 + rng.uniform(-cfg.colour_temperature_jitter, cfg.colour_temperature_jitter, 3)
    rgb = kelvin_to_rgb(kelvin) * tint
    return np.round(rgb / rgb.max(), 6).tolist(), round(kelvin, 3)


def _key_shadow(
    rng: np.random.Generator, cfg: LightingConfig
) -> tuple[bool, Literal["hard", "soft"] | None, float | None]:
    """The key light's shadow, its edge and the radius (metres) of the area light a soft one
    comes from; probability 0 draws nothing."""
    if not cfg.shadows:
        return False, None, None
    if cfg.soft_shadow_probability > 0 and rng.uniform() < cfg.soft_shadow_probability:
        return True, "soft", uniform(rng, cfg.soft_shadow_radius_m)
    return True, "hard", None


def draw_lighting(
    rng: np.random.Generator, cfg: LightingConfig, target: tuple[float, float, float]
) -> Lighting:
    """The ambient level, a directional key light and spot fill lights aimed at ``target``
    (the tray, metres) from ``FILL_DISTANCE``."""
    lights = []
    for i in range(int(rng.integers(cfg.lights[0], cfg.lights[1] + 1))):
        direction = light_direction(rng, cfg)
        colour, kelvin = light_colour(rng, cfg)
        towards = tuple(np.round(direction, 6).tolist())
        intensity = uniform(rng, cfg.intensity)
        if i == 0:
            shadow, edge, radius = _key_shadow(rng, cfg)
            lights.append(
                Light(
                    "directional",
                    tuple(colour),
                    intensity,
                    shadow,
                    direction=towards,
                    temperature_k=kelvin,
                    shadow_edge=edge,
                    area_radius_m=radius,
                )
            )
            continue
        shadow = bool(cfg.shadows and rng.uniform() < 0.5)
        distance = rng.uniform(*FILL_DISTANCE)
        position = tuple(np.round(np.asarray(target) - direction * distance, 6).tolist())
        fov = uniform(rng, (50, 90))
        lights.append(
            Light(
                "spot",
                tuple(colour),
                intensity,
                shadow,
                towards,
                position,
                kelvin,
                outer_fov_deg=fov,
            )
        )
    ambient = uniform(rng, cfg.ambient)
    return Lighting(ambient, tuple(lights), target=tuple(float(x) for x in target))
