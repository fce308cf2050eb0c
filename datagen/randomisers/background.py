"""Background randomiser (stream ``background``): a room around the table, with four backdrop
walls at random distances, an optional ceiling, textured walls (procedural or users'
pictures) and point lights under the ceiling (or at the wall tops) that light the scene.

Stored values (``randomisation.background``), world metres, the table centred on the origin::

    {"room": {"x": [x_min, x_max], "y": [y_min, y_max], "height": h}, "ceiling": bool,
     "walls": {"x_min": material, "x_max": ..., "y_min": ..., "y_max": ..., "ceiling": ...},
     "lights": [{"position": [x, y, z], "colour": [r, g, b], "intensity": i}, ...]}

Walls and ceiling are drawn only (no collision) and labelled with the stuff class ``wall``;
where they stand: :mod:`datagen.assets.backdrop`; built by :mod:`datagen.worlds.realise`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from datagen.assets.texture_tiles import draw_texture
from datagen.config.appearance import BackgroundConfig, PhotosConfig
from datagen.config.sections import MaterialsConfig
from datagen.randomisers.materials import random_material
from datagen.randomisers.textures import DEFAULT_PHOTOS, draw_picture
from datagen.scene_values.material import Material
from datagen.scene_values.rounding import uniform

WALL_SATURATION = (0.0, 0.4)  # HSV: painted walls are muted
WALL_VALUE = (0.3, 0.95)
WALL_TEXTURE_SCALE_M = (0.2, 1.5)  # metres per repeat of a procedural wall pattern
LIGHT_COLOUR_JITTER = 0.1  # largest per-channel deviation of a room light's colour
WALLS = ("x_min", "x_max", "y_min", "y_max")


def _wall_material(
    rng: np.random.Generator,
    cfg: BackgroundConfig,
    materials: MaterialsConfig,
    photos: PhotosConfig,
) -> Material:
    drawn = random_material(rng, materials, WALL_SATURATION, WALL_VALUE)
    material = replace(drawn, metallic=0.0)
    textured, use_picture = rng.random() < cfg.texture_probability, rng.random()
    if textured and cfg.images_dir and use_picture < cfg.images_dir_share:
        scale_m = photos.backdrop_scale_m  # as a photograph on a wall
        return material.with_texture(
            draw_picture(rng, cfg.images_dir, photos, scale_m, rotate=False)
        )
    if textured:
        colour = list(material.base_color)
        families = materials.texture_families
        return material.with_texture(draw_texture(rng, colour, families, WALL_TEXTURE_SCALE_M))
    return material


def draw_background(
    rng: np.random.Generator,
    cfg: BackgroundConfig,
    materials: MaterialsConfig,
    target: tuple[float, float, float],
    photos: PhotosConfig = DEFAULT_PHOTOS,
) -> dict[str, Any]:
    """The room's values; room lights are scaled to their radiance at ``target`` (the tray).
    A picture of ``background.images_dir`` is drawn as a photograph is on a wall (``photos``'
    crop, jitter and ``backdrop_scale_m``), upright."""
    x_min, x_max, y_min, y_max = (uniform(rng, cfg.room_half_size) for _ in WALLS)
    height = uniform(rng, cfg.wall_height)
    ceiling = bool(rng.random() < cfg.ceiling_probability)
    walls = {name: _wall_material(rng, cfg, materials, photos) for name in (*WALLS, "ceiling")}
    lights = []
    for _ in range(int(rng.integers(cfg.room_lights[0], cfg.room_lights[1] + 1))):
        x = rng.uniform(-x_min, x_max) * 0.8
        y = rng.uniform(-y_min, y_max) * 0.8
        z = height - 0.1 if ceiling else height * rng.uniform(0.6, 0.95)
        tint = 1.0 + rng.uniform(-LIGHT_COLOUR_JITTER, LIGHT_COLOUR_JITTER, 3)
        lights.append(
            {
                "position": [round(float(v), 6) for v in (x, y, z)],
                "colour": np.round(tint / tint.max(), 6).tolist(),
                "intensity": uniform(rng, cfg.room_light_intensity),
            }
        )
    return {
        "room": {"x": [-x_min, x_max], "y": [-y_min, y_max], "height": height},
        "ceiling": ceiling,
        "walls": walls if ceiling else {k: v for k, v in walls.items() if k != "ceiling"},
        "lights": lights,
        "target": [float(v) for v in target],
    }
