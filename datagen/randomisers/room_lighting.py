"""Lighting over a floor plan, for the families whose worlds are rooms (navigation) and volumes
(aerial): a directional key light with a shadow volume over the whole plan, and ceiling point
lights over free cells."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from datagen.config import BuildConfig
from datagen.floorplans.grid import Layout
from datagen.randomisers.lighting import light_direction
from datagen.scene_values.lighting import Light, Lighting
from datagen.scene_values.rounding import uniform

CEILING_LIGHT_BELOW_TOP = 0.2  # metres below the top of the walls
LAMP_CLEARANCE = 0.8  # metres


def draw_nav_lighting(rng, config: BuildConfig, layout: Layout, top: float) -> Lighting:
    """A directional key light with a shadow volume over the whole floor plan, and ceiling
    point lights over free cells for the other lights the config asks for."""
    cfg = config.lighting
    width, depth = layout.size_m
    # ceiling lights over cells at least LAMP_CLEARANCE from any wall or obstacle (else anywhere free)
    clearance = ndimage.distance_transform_edt(~layout.grid) * layout.resolution
    free = np.argwhere(clearance >= LAMP_CLEARANCE)
    free = free if len(free) else np.argwhere(~layout.grid)
    lights = []
    for i in range(int(rng.integers(max(cfg.lights[0], 1), max(cfg.lights[1], 1) + 1))):
        tint = 1.0 + rng.uniform(-cfg.colour_temperature_jitter, cfg.colour_temperature_jitter, 3)
        colour = tuple(np.round(tint / tint.max(), 6).tolist())
        intensity = uniform(rng, cfg.intensity)
        shadow = bool(cfg.shadows and i == 0)
        if i == 0:
            direction = tuple(np.round(light_direction(rng, cfg), 6).tolist())
            lights.append(Light("directional", colour, intensity, shadow, direction=direction))
        else:
            r, c = free[rng.integers(len(free))]
            res = layout.resolution
            z = top - CEILING_LIGHT_BELOW_TOP
            position = (round((c + 0.5) * res, 4), round((r + 0.5) * res, 4), z)
            lights.append(Light("point", colour, intensity, shadow, position=position))
    return Lighting(
        ambient=uniform(rng, cfg.ambient),
        lights=tuple(lights),
        shadow_centre=(round(width / 2, 4), round(depth / 2, 4), round(top / 2, 4)),
        shadow_half_extent=round(max(width, depth) / 2 + 0.5, 4),
    )
