"""Texture randomiser: which surfaces are textured and with what (stream ``textures``). The
worlds draw the stored values (:mod:`datagen.worlds.surfaces`), the USD export too.

The stored values are those of :mod:`datagen.assets.texture_tiles`; a picture from a user's folder is
``{"family": "image", "root", "path", "sha256", "crop", "flip", "contrast", "brightness",
"saturation", "hue_deg", "aspect", "scale_m", "rotation_deg"}``: cropped, mirrored, jittered and
sized as a photograph of the library is (:func:`datagen.randomisers.photos.draw_look`, within
the ``photos`` section's ranges, enabled or not), on surfaces ``photos.surface_scale_m`` across.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.assets.image_library import load_library
from datagen.assets.texture_tiles import IMAGE_FAMILY, draw_texture
from datagen.config.appearance import PhotosConfig
from datagen.config.sections import MaterialsConfig
from datagen.randomisers.photos import draw_look
from datagen.scene_values.material import Material

SURFACES = ("table", "tray", "floor")  # the room's surfaces in materials, after the objects
DEFAULT_PHOTOS = PhotosConfig()  # the ranges for a caller that has no photos section at hand


def draw_picture(
    rng: np.random.Generator,
    root: str,
    photos: PhotosConfig,
    scale_m: tuple[float, float],
    rotate: bool = True,
) -> dict[str, Any]:
    """A picture drawn from a user's folder, as stored texture values: cropped, mirrored and
    jittered within ``photos``' ranges, ``scale_m`` metres across."""
    pictures = load_library(root).pictures
    picture = pictures[int(rng.integers(len(pictures)))]
    return {
        "family": IMAGE_FAMILY,
        "root": root,
        "path": picture.path,
        "sha256": picture.sha256,
        **draw_look(rng, photos, picture.height / picture.width, scale_m, rotate),
    }


def draw_surface_texture(
    rng: np.random.Generator,
    base_color: list[float],
    cfg: MaterialsConfig,
    photos: PhotosConfig,
) -> dict[str, Any]:
    """A picture of ``materials.textures_dir`` with probability ``textures_dir_share`` (when a
    folder is set), else a procedural texture around the surface's colour."""
    use_picture = rng.random() < cfg.textures_dir_share
    if cfg.textures_dir and use_picture:
        values = draw_picture(rng, cfg.textures_dir, photos, photos.surface_scale_m)
    else:
        values = draw_texture(rng, base_color, cfg.texture_families, cfg.texture_scale_m)
    if cfg.normal_maps:
        values["normal_map"] = True
    return values


def add_textures(
    rng: np.random.Generator,
    cfg: MaterialsConfig,
    materials: dict[str, Any],
    photos: PhotosConfig = DEFAULT_PHOTOS,
) -> dict[str, Any]:
    """``materials`` (as :func:`draw_materials` drew them) with a ``texture`` on each surface
    drawn to be textured: every object, then table, tray and floor, one draw each, so
    ``texture_probability`` 0 leaves every material exactly as it was."""
    objects = [maybe_texture(rng, m, cfg, photos) for m in materials["objects"]]
    surfaces = {name: maybe_texture(rng, materials[name], cfg, photos) for name in SURFACES}
    return {**materials, "objects": objects, **surfaces}


def maybe_texture(
    rng: np.random.Generator,
    material: Material,
    cfg: MaterialsConfig,
    photos: PhotosConfig = DEFAULT_PHOTOS,
) -> Material:
    """``material`` with a ``texture`` with ``materials.texture_probability`` (one draw, then
    the texture's own draws when it is textured), else ``material`` itself."""
    if rng.random() < cfg.texture_probability:
        colour = list(material.base_color)
        return material.with_texture(draw_surface_texture(rng, colour, cfg, photos))
    return material


def texture_surfaces(
    rng: np.random.Generator,
    cfg: MaterialsConfig,
    materials: dict[str, Any],
    names: tuple[str, ...],
    photos: PhotosConfig = DEFAULT_PHOTOS,
) -> dict[str, Any]:
    """``materials`` with a ``texture`` on each of the surfaces ``names`` drawn to be textured
    (one draw each, in order; the navigation scenes' floor, walls and doors)."""
    textured = dict(materials)
    for name in names:
        textured[name] = maybe_texture(rng, materials[name], cfg, photos)
    return textured
