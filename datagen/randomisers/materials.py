"""Material randomiser: base colour, roughness and metallic of objects, table, tray and floor
(their textures: :mod:`datagen.randomisers.textures`, a stream of their own), and the
class-free colours of a scene (stream ``colours``): :func:`class_free_colours`."""

from __future__ import annotations

import colorsys
from dataclasses import replace
from typing import Any

import numpy as np

from datagen.assets.texture_tiles import draw_palette
from datagen.config.sections import MaterialsConfig
from datagen.scene_values.material import Material
from datagen.scene_values.rounding import uniform

# Surfaces of the room keep plausible colour ranges (HSV value), objects span the config's.
_SURFACE_VALUE = {"table": (0.35, 0.85), "tray": (0.2, 0.9), "floor": (0.25, 0.75)}
# HSV of the class-free colours: any hue, the same for surfaces and objects (issue 26)
CLASS_FREE_SATURATION = (0.0, 1.0)
CLASS_FREE_VALUE = (0.1, 1.0)


def random_colour(
    rng: np.random.Generator, saturation: tuple[float, float], value: tuple[float, float]
) -> list[float]:
    rgb = colorsys.hsv_to_rgb(rng.uniform(0, 1), rng.uniform(*saturation), rng.uniform(*value))
    return [round(float(c), 6) for c in rgb] + [1.0]


def random_material(rng: np.random.Generator, cfg: MaterialsConfig, saturation, value) -> Material:
    return Material(
        base_color=tuple(random_colour(rng, saturation, value)),
        roughness=uniform(rng, cfg.roughness),
        metallic=uniform(rng, cfg.metallic),
    )


def draw_marker_material(rng: np.random.Generator) -> Material:
    """A goal marker's look: a light, saturated colour, half rough, not metallic."""
    colour = random_colour(rng, (0.8, 1.0), (0.8, 1.0))
    return Material(base_color=tuple(colour), roughness=0.5, metallic=0.0)


def draw_materials(
    rng: np.random.Generator, cfg: MaterialsConfig, num_objects: int
) -> dict[str, Any]:
    surfaces = {
        name: random_material(rng, cfg, (0.0, 0.5), value) for name, value in _SURFACE_VALUE.items()
    }
    objects = [random_material(rng, cfg, cfg.saturation, cfg.value) for _ in range(num_objects)]
    return {"objects": objects, **surfaces}


def _recoloured(rng: np.random.Generator, material: Material) -> Material:
    """``material`` with a class-free base colour; a procedural texture's palette is drawn
    again around it (the tile's pattern stays), a picture is left as it is."""
    colour = random_colour(rng, CLASS_FREE_SATURATION, CLASS_FREE_VALUE)
    recoloured = replace(material, base_color=tuple(colour))
    texture = material.texture
    if texture is not None and "palette" in texture:
        recoloured = recoloured.with_texture({**texture, "palette": draw_palette(rng, colour)})
    return recoloured


def class_free_colours(
    rng: np.random.Generator, cfg: MaterialsConfig, params: dict[str, Any]
) -> dict[str, Any]:
    """A scene's values (``draw_scene``'s, materials and any background drawn) with, with
    ``cfg.class_independent_probability`` (one draw), every object's, the table's, tray's,
    floor's and the room's walls' base colour drawn from one class-free distribution, so
    colour statistics tell no class from another; else ``params`` itself, unchanged."""
    if not rng.random() < cfg.class_independent_probability:
        return params
    materials = params["materials"]
    recoloured = {
        **materials,
        "objects": [_recoloured(rng, m) for m in materials["objects"]],
        **{surface: _recoloured(rng, materials[surface]) for surface in _SURFACE_VALUE},
    }
    scene = {**params, "materials": recoloured}
    if "background" in params:
        walls = params["background"]["walls"]
        walls = {name: _recoloured(rng, material) for name, material in walls.items()}
        scene["background"] = {**params["background"], "walls": walls}
    return scene
