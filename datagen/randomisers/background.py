"""Background randomiser (stream ``background``): a room around the table, with four backdrop
walls at random distances, an optional ceiling, textured walls (procedural or users'
pictures) and point lights under the ceiling (or at the wall tops) that light the scene.

Stored values (``randomisation.background``), world metres, the table centred on the origin::

    {"room": {"x": [x_min, x_max], "y": [y_min, y_max], "height": h}, "ceiling": bool,
     "walls": {"x_min": material, "x_max": ..., "y_min": ..., "y_max": ..., "ceiling": ...},
     "lights": [{"position": [x, y, z], "colour": [r, g, b], "intensity": i}, ...]}

Walls and ceiling are drawn only (no collision) and labelled with the stuff class ``wall``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien

from datagen.assets.backdrop import wall_boxes
from datagen.config.appearance import BackgroundConfig
from datagen.config.sections import MaterialsConfig
from datagen.randomisers.materials import random_material
from datagen.randomisers.textures import sample_picture, sample_texture, surface_entity

WALL_SATURATION = (0.0, 0.4)  # HSV: painted walls are muted
WALL_VALUE = (0.3, 0.95)
WALL_TEXTURE_SCALE_M = (0.2, 1.5)  # metres per repeat of a procedural wall pattern
PICTURE_SCALE_M = (1.0, 4.0)  # metres across one repeat of a user's backdrop picture
LIGHT_COLOUR_JITTER = 0.1  # largest per-channel deviation of a room light's colour
WALLS = ("x_min", "x_max", "y_min", "y_max")


def _wall_material(
    rng: np.random.Generator, cfg: BackgroundConfig, materials: MaterialsConfig
) -> dict[str, Any]:
    material = random_material(rng, materials, WALL_SATURATION, WALL_VALUE)
    material["metallic"] = 0.0
    textured, use_picture = rng.random() < cfg.texture_probability, rng.random()
    if textured and cfg.images_dir and use_picture < cfg.images_dir_share:
        material["texture"] = sample_picture(rng, cfg.images_dir, PICTURE_SCALE_M, rotate=False)
    elif textured:
        material["texture"] = sample_texture(
            rng, material["base_color"], materials.texture_families, WALL_TEXTURE_SCALE_M
        )
    return material


def sample_background(
    rng: np.random.Generator,
    cfg: BackgroundConfig,
    materials: MaterialsConfig,
    target: tuple[float, float, float],
) -> dict[str, Any]:
    """The room's values; room lights are scaled to their radiance at ``target`` (the tray)."""
    x_min, x_max, y_min, y_max = (round(float(rng.uniform(*cfg.room_half_size)), 6) for _ in WALLS)
    height = round(float(rng.uniform(*cfg.wall_height)), 6)
    ceiling = bool(rng.random() < cfg.ceiling_probability)
    walls = {name: _wall_material(rng, cfg, materials) for name in (*WALLS, "ceiling")}
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
                "intensity": round(float(rng.uniform(*cfg.room_light_intensity)), 6),
            }
        )
    return {
        "room": {"x": [-x_min, x_max], "y": [-y_min, y_max], "height": height},
        "ceiling": ceiling,
        "walls": walls if ceiling else {k: v for k, v in walls.items() if k != "ceiling"},
        "lights": lights,
        "target": [float(v) for v in target],
    }


def add_background(scene: sapien.Scene, values: dict[str, Any] | None) -> list[sapien.Entity]:
    """Apply step: the walls (and ceiling) as drawn-only entities, and the room lights; nothing
    for ``None`` (background off)."""
    entities: list[sapien.Entity] = []
    if values is None:
        return entities
    for name, (half_size, centre) in wall_boxes(values).items():
        entity = surface_entity(
            scene, f"wall_{name}", [(half_size, [0, 0, 0])], values["walls"][name], collide=False
        )
        entity.set_pose(sapien.Pose(centre))
        entities.append(entity)
    for light in values["lights"]:
        # point radiance falls off with the squared distance: intensity is the radiance at the tray
        distance_sq = float(np.sum((np.asarray(light["position"]) - values["target"]) ** 2))
        colour = np.asarray(light["colour"]) * light["intensity"] * distance_sq
        scene.add_point_light(light["position"], colour.tolist(), shadow=False)
    return entities


def lit_by_room(lighting: dict[str, Any], values: dict[str, Any] | None) -> dict[str, Any]:
    """The lighting values to apply under this room: with a ceiling, the key light's shadow
    casters stop 5 cm below it (``shadow_near``, metres along the light from its shadow centre
    at z = 1 m), so the ceiling does not shade the whole scene; unchanged without one."""
    if not values or not values["ceiling"]:
        return lighting
    centre_z = lighting.get("shadow_centre", [0, 0, 1])[2]
    default_near = -2.0 * lighting.get("shadow_half_extent", 1.5)  # as apply_lighting's
    near = max(-(values["room"]["height"] - centre_z - 0.05), default_near)
    return {**lighting, "shadow_near": near}
