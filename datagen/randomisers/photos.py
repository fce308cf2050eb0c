"""Photograph randomiser: pictures of the library's training sources (``photos.sources``) on
the tabletop scene's surfaces (stream ``photos.surfaces``), on the room's walls and ceiling
(stream ``photos.backdrops``), and on flying distractors (:func:`draw_photo`, called from
theirs). ``photos.held_out`` sources are never drawn. A user's picture
(``materials.textures_dir``, ``background.images_dir``) is drawn with the same crop, jitter
and scale (:func:`draw_look`, called from :mod:`datagen.randomisers.textures`).

A photograph's stored texture values (drawn by :mod:`datagen.assets.texture_tiles`)::

    {"family": "photo", "source": ..., "path": <path in the library>, "sha256": ...,
     "crop": [x0, y0, side], "flip": bool, "contrast": c, "brightness": b, "saturation": s,
     "hue_deg": h, "aspect": height / width of the crop, "scale_m": ..., "rotation_deg": ...}

``crop`` is the top-left corner and the side of a crop, as fractions of the picture's width
and height (so the crop keeps the picture's aspect).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.config.appearance import PhotosConfig
from datagen.library.catalogue import pictures
from datagen.scene_values.material import Material

PHOTO_FAMILY = "photo"
SURFACES = ("table", "tray", "floor")


def _round(value: float) -> float:
    return round(float(value), 6)


def draw_photo(
    rng: np.random.Generator, cfg: PhotosConfig, scale_m: tuple[float, float], rotate: bool = True
) -> dict[str, Any]:
    """One photograph of the training sources with its crop, placement and colour jitter."""
    choices = pictures(cfg.sources)
    picture = choices[int(rng.integers(len(choices)))]
    return {
        "family": PHOTO_FAMILY,
        "source": picture["source"],
        "path": picture["path"],
        "sha256": picture["sha256"],
        **draw_look(rng, cfg, picture["height"] / picture["width"], scale_m, rotate),
    }


def draw_look(
    rng: np.random.Generator,
    cfg: PhotosConfig,
    aspect: float,
    scale_m: tuple[float, float],
    rotate: bool = True,
) -> dict[str, Any]:
    """How a picture of ``aspect`` (height / width) is drawn: its crop, mirroring and colour
    jitter within ``cfg``'s ranges, its size and rotation on the surface; the keys after the
    picture's own in a photograph's stored values (a user's picture draws the same)."""
    side = float(rng.uniform(*cfg.crop))
    return {
        "crop": [_round(rng.uniform(0, 1 - side)), _round(rng.uniform(0, 1 - side)), _round(side)],
        "flip": bool(rng.random() < 0.5),
        "contrast": _round(rng.uniform(*cfg.contrast)),
        "brightness": _round(rng.uniform(*cfg.brightness)),
        "saturation": _round(rng.uniform(*cfg.saturation)),
        "hue_deg": _round(rng.uniform(*cfg.hue_deg)),
        "aspect": _round(aspect),
        "scale_m": _round(rng.uniform(*scale_m)),
        "rotation_deg": _round(rng.uniform(0.0, 360.0)) if rotate else 0.0,
    }


def add_photo_surfaces(
    rng: np.random.Generator, cfg: PhotosConfig, materials: dict[str, Any]
) -> dict[str, Any]:
    """``materials`` with a photograph, with ``surface_probability`` each (one draw per
    surface, then the photograph's), on every object, then the table, tray and floor."""

    def shown(material: Material) -> Material:
        if rng.random() < cfg.surface_probability:
            return material.with_texture(draw_photo(rng, cfg, cfg.surface_scale_m))
        return material

    objects = [shown(m) for m in materials["objects"]]
    return {**materials, "objects": objects, **{name: shown(materials[name]) for name in SURFACES}}


def add_photo_backdrops(
    rng: np.random.Generator, cfg: PhotosConfig, background: dict[str, Any]
) -> dict[str, Any]:
    """The room's values with a photograph, with ``backdrop_probability`` each, on its walls
    (and ceiling), upright: a picture behind the scene, as a photographed room has."""
    walls = dict(background["walls"])
    for name, wall in walls.items():
        if rng.random() < cfg.backdrop_probability:
            walls[name] = wall.with_texture(
                draw_photo(rng, cfg, cfg.backdrop_scale_m, rotate=False)
            )
    return {**background, "walls": walls}
