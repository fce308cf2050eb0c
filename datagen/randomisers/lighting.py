"""Lighting randomiser: ambient level, a directional key light and 0-2 spot fill lights
(direction, colour, intensity, shadows). SAPIEN's default shader supports one shadow-casting
directional light, so fill lights are spot lights aimed at the tray."""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.config.sections import LightingConfig

FILL_DISTANCE = (1.0, 1.8)  # metres from the light target


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


def sample_lighting(
    rng: np.random.Generator, cfg: LightingConfig, target: tuple[float, float, float]
) -> dict[str, Any]:
    lights = []
    for i in range(int(rng.integers(cfg.lights[0], cfg.lights[1] + 1))):
        direction = light_direction(rng, cfg)
        tint = 1.0 + rng.uniform(-cfg.colour_temperature_jitter, cfg.colour_temperature_jitter, 3)
        light = {
            "type": "directional" if i == 0 else "spot",
            "direction": np.round(direction, 6).tolist(),
            "colour": np.round(tint / tint.max(), 6).tolist(),
            "intensity": round(float(rng.uniform(*cfg.intensity)), 6),
            "shadow": bool(cfg.shadows and (i == 0 or rng.uniform() < 0.5)),
        }
        if light["type"] == "spot":
            distance = rng.uniform(*FILL_DISTANCE)
            light["position"] = np.round(np.asarray(target) - direction * distance, 6).tolist()
            light["outer_fov_deg"] = round(float(rng.uniform(50, 90)), 6)
        lights.append(light)
    ambient = round(float(rng.uniform(*cfg.ambient)), 6)
    return {"ambient": ambient, "target": [float(x) for x in target], "lights": lights}
