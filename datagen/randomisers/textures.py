"""Texture randomiser: which surfaces are textured and with what (stream ``textures``). The
worlds draw the stored values (:mod:`datagen.worlds.surfaces`), the USD export too.

The stored values are those of :mod:`datagen.assets.texture_tiles`; a picture from a user's folder is
``{"family": "image", "root", "path", "sha256", "aspect", "scale_m", "rotation_deg"}``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.assets.image_library import load_library
from datagen.assets.texture_tiles import IMAGE_FAMILY, sample_texture
from datagen.config.sections import MaterialsConfig

SURFACES = ("table", "tray", "floor")  # the room's surfaces in materials, after the objects


def sample_picture(
    rng: np.random.Generator, root: str, scale_m: tuple[float, float], rotate: bool = True
) -> dict[str, Any]:
    """A picture drawn from a user's folder, as stored texture values."""
    pictures = load_library(root).pictures
    picture = pictures[int(rng.integers(len(pictures)))]
    return {
        "family": IMAGE_FAMILY,
        "root": root,
        "path": picture.path,
        "sha256": picture.sha256,
        "aspect": round(picture.height / picture.width, 6),
        "scale_m": round(float(rng.uniform(*scale_m)), 6),
        "rotation_deg": round(float(rng.uniform(0.0, 360.0)), 6) if rotate else 0.0,
    }


def sample_surface_texture(
    rng: np.random.Generator,
    base_color: list[float],
    cfg: MaterialsConfig,
    pictures_root: str,
    pictures_share: float,
    scale_m: tuple[float, float],
) -> dict[str, Any]:
    """A picture of ``pictures_root`` with probability ``pictures_share`` (when a folder is
    set), else a procedural texture around the surface's colour."""
    use_picture = rng.random() < pictures_share
    if pictures_root and use_picture:
        values = sample_picture(rng, pictures_root, scale_m)
    else:
        values = sample_texture(rng, base_color, cfg.texture_families, scale_m)
    if cfg.normal_maps:
        values["normal_map"] = True
    return values


def add_textures(
    rng: np.random.Generator, cfg: MaterialsConfig, materials: dict[str, Any]
) -> dict[str, Any]:
    """``materials`` (as :func:`sample_materials` drew them) with a ``texture`` on each surface
    drawn to be textured: every object, then table, tray and floor, one draw each, so
    ``texture_probability`` 0 leaves every material exactly as it was."""
    textured = {
        **materials,
        "objects": [dict(m) for m in materials["objects"]],
        **{surface: dict(materials[surface]) for surface in SURFACES},
    }
    for material in [*textured["objects"], *(textured[surface] for surface in SURFACES)]:
        maybe_texture(rng, material, cfg)
    return textured


def maybe_texture(rng: np.random.Generator, material: dict[str, Any], cfg: MaterialsConfig) -> None:
    """Gives ``material`` a ``texture`` with ``materials.texture_probability`` (one draw, then
    the texture's own draws when it is textured)."""
    if rng.random() < cfg.texture_probability:
        material["texture"] = sample_surface_texture(
            rng,
            material["base_color"],
            cfg,
            cfg.textures_dir,
            cfg.textures_dir_share,
            cfg.texture_scale_m,
        )


def texture_surfaces(
    rng: np.random.Generator,
    cfg: MaterialsConfig,
    materials: dict[str, Any],
    names: tuple[str, ...],
) -> dict[str, Any]:
    """``materials`` with a ``texture`` on each of the surfaces ``names`` drawn to be textured
    (one draw each, in order; the navigation scenes' floor, walls and doors)."""
    textured = dict(materials)
    for name in names:
        textured[name] = dict(materials[name])
        if rng.random() < cfg.texture_probability:
            textured[name]["texture"] = sample_surface_texture(
                rng,
                textured[name]["base_color"],
                cfg,
                cfg.textures_dir,
                cfg.textures_dir_share,
                cfg.texture_scale_m,
            )
    return textured
