"""Material randomiser: base colour, roughness and metallic of objects, table, tray and floor
(their textures: :mod:`datagen.randomisers.textures`, a stream of their own)."""

from __future__ import annotations

import colorsys
from typing import Any

import numpy as np

from datagen.config.sections import MaterialsConfig

# Surfaces of the room keep plausible colour ranges (HSV value), objects span the config's.
_SURFACE_VALUE = {"table": (0.35, 0.85), "tray": (0.2, 0.9), "floor": (0.25, 0.75)}


def random_colour(
    rng: np.random.Generator, saturation: tuple[float, float], value: tuple[float, float]
) -> list[float]:
    rgb = colorsys.hsv_to_rgb(rng.uniform(0, 1), rng.uniform(*saturation), rng.uniform(*value))
    return [round(float(c), 6) for c in rgb] + [1.0]


def random_material(
    rng: np.random.Generator, cfg: MaterialsConfig, saturation, value
) -> dict[str, Any]:
    return {
        "base_color": random_colour(rng, saturation, value),
        "roughness": round(float(rng.uniform(*cfg.roughness)), 6),
        "metallic": round(float(rng.uniform(*cfg.metallic)), 6),
    }


def sample_materials(
    rng: np.random.Generator, cfg: MaterialsConfig, num_objects: int
) -> dict[str, Any]:
    surfaces = {
        name: random_material(rng, cfg, (0.0, 0.5), value) for name, value in _SURFACE_VALUE.items()
    }
    objects = [random_material(rng, cfg, cfg.saturation, cfg.value) for _ in range(num_objects)]
    return {"objects": objects, **surfaces}
