"""Seeded procedural textures (pure numpy: stored values in, an RGB tile out).

A texture's stored values (``randomisation.materials.<surface>.texture``) are plain JSON::

    {"family": "marble", "palette": [[r, g, b], ...], "seed": 123, "scale_m": 0.2,
     "rotation_deg": 40.0}

``family`` is one of :data:`TEXTURE_FAMILIES`, or ``image`` (a user's picture: ``root``,
``path`` and ``sha256`` instead of ``palette`` and ``seed``, with a photograph's crop and colour
jitter) or ``photo`` (a picture of the library, :mod:`datagen.randomisers.photos`). The
pattern's own generator is seeded by ``seed``, so the tile is rebuilt from these values alone
(replay, USD export). Every tile is periodic (it repeats without seams); ``scale_m`` is metres
per repeat and ``rotation_deg`` turns the pattern on the surface: both act on the texture
coordinates (:func:`surface_uv`), so a pattern looks the same size on a cup and on the table.

Convention: tiles are stored as sRGB-encoded uint8 and given to SAPIEN as ``R8G8B8A8Unorm``
with ``srgb=False``, the same for procedural tiles and users' pictures (docs/platform.md).
"""

from __future__ import annotations

import colorsys
import functools
import json
from typing import Any

import cv2
import numpy as np

from datagen.assets.family_names import TEXTURE_FAMILIES

PHOTO_FAMILY = "photo"  # a picture of the installed library (datagen.randomisers.photos)
IMAGE_FAMILY = "image"  # a picture from materials.textures_dir / background.images_dir
TILE_SIZE = 128  # pixels per side of a procedural tile


def _grid(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-centre coordinates in [0, 1) of a square tile, (size, size) each."""
    axis = (np.arange(size) + 0.5) / size
    return np.meshgrid(axis, axis, indexing="xy")


@functools.lru_cache(maxsize=32)
def _wrap_weights(cells: int, size: int) -> np.ndarray:
    """(size, cells): weights that smoothstep-interpolate a periodic lattice of ``cells``
    values at the tile's pixel centres (value noise is separable: W @ lattice @ W.T)."""
    f = (np.arange(size) + 0.5) / size * cells
    left = np.floor(f).astype(int)
    t = f - left
    t = t * t * (3 - 2 * t)  # smoothstep
    weights = np.zeros((size, cells))
    rows = np.arange(size)
    np.add.at(weights, (rows, left % cells), 1 - t)
    np.add.at(weights, (rows, (left + 1) % cells), t)
    weights.flags.writeable = False
    return weights


def periodic_value_noise(rng: np.random.Generator, size: int, octaves: int = 4) -> np.ndarray:
    """Fractal value noise in [0, 1], periodic over the tile: (size, size) float."""
    total, weight = np.zeros((size, size)), 0.0
    for octave in range(octaves):
        cells = 4 * 2**octave
        lattice = rng.random((cells, cells))
        interpolate = _wrap_weights(cells, size)
        amplitude = 0.5**octave
        total += amplitude * (interpolate @ lattice @ interpolate.T)
        weight += amplitude
    total /= weight
    return (total - total.min()) / max(float(np.ptp(total)), 1e-9)


def _stripes(rng: np.random.Generator, size: int) -> np.ndarray:
    x, y = _grid(size)
    kx, ky = int(rng.integers(2, 9)), int(rng.integers(0, 3))  # whole stripes per tile side
    sharpness = rng.uniform(1.0, 8.0)
    wave = np.sin(2 * np.pi * (kx * x + ky * y))
    return 0.5 + 0.5 * np.tanh(sharpness * wave) / np.tanh(sharpness)


def _checker(rng: np.random.Generator, size: int) -> np.ndarray:
    x, y = _grid(size)
    cells = 2 * int(rng.integers(1, 5))  # even, so the tile repeats seamlessly
    return ((np.floor(x * cells) + np.floor(y * cells)) % 2).astype(float)


def _marble(rng: np.random.Generator, size: int) -> np.ndarray:
    x, y = _grid(size)
    turbulence = periodic_value_noise(rng, size, octaves=5)
    veins = int(rng.integers(1, 4))
    strength = rng.uniform(2.0, 6.0)
    return 0.5 + 0.5 * np.sin(2 * np.pi * (veins * (x + y) + strength * turbulence))


def _grain(rng: np.random.Generator, size: int) -> np.ndarray:
    """Wood-like: rings warped by low-frequency noise, plus fine fibres along them."""
    _, y = _grid(size)
    warp = periodic_value_noise(rng, size, octaves=2)
    rings = int(rng.integers(3, 10))
    phase = rings * y + rng.uniform(0.5, 2.0) * warp
    fibres = periodic_value_noise(rng, size, octaves=5)
    return np.clip(0.8 * (phase % 1.0) ** 1.5 + 0.2 * fibres, 0, 1)


def _speckle(rng: np.random.Generator, size: int) -> np.ndarray:
    base = 0.35 * periodic_value_noise(rng, size, octaves=3)
    dots = rng.random((size, size)) < rng.uniform(0.01, 0.06)
    if rng.random() < 0.5:  # bigger dots: grown by one pixel, wrapping round the edges
        dots = dots | np.roll(dots, 1, 0) | np.roll(dots, 1, 1) | np.roll(dots, (1, 1), (0, 1))
    return np.where(dots, 1.0, base)


_PATTERNS = {
    "noise": lambda rng, size: periodic_value_noise(rng, size),
    "stripes": _stripes,
    "checker": _checker,
    "marble": _marble,
    "grain": _grain,
    "speckle": _speckle,
}


def pattern(family: str, seed: int, size: int = TILE_SIZE) -> np.ndarray:
    """The family's periodic scalar field in [0, 1], (size, size) float, from its seed."""
    if family not in _PATTERNS:
        raise ValueError(f"unknown texture family {family!r}; expected one of {TEXTURE_FAMILIES}")
    return _PATTERNS[family](np.random.default_rng(seed), size)


def apply_palette(field: np.ndarray, palette: list[list[float]]) -> np.ndarray:
    """Maps a [0, 1] field through the palette's colours (piecewise linear): (H, W, 3) uint8."""
    colours = np.asarray(palette, float)[:, :3]
    stops, levels = np.linspace(0.0, 1.0, len(colours)), np.linspace(0.0, 1.0, 256)
    lut = np.stack([np.interp(levels, stops, colours[:, c]) for c in range(3)], axis=-1)
    lut = np.round(np.clip(lut, 0, 1) * 255).astype(np.uint8)  # (256, 3): the field in 8 bits
    return lut[np.round(np.clip(field, 0, 1) * 255).astype(np.uint8)]


def draw_palette(rng: np.random.Generator, base_color: list[float]) -> list[list[float]]:
    """2-4 colours: the surface's own colour, then harmonies of it (analogous, complementary or
    triadic hues) at varied saturation and value."""
    h, s, v = colorsys.rgb_to_hsv(*base_color[:3])
    offsets = {
        "analogous": (-0.08, 0.08, 0.16),
        "complementary": (0.5, 0.0, 0.5),
        "triadic": (1 / 3, 2 / 3, 0.0),
        "tonal": (0.0, 0.0, 0.0),
    }[str(rng.choice(["analogous", "complementary", "triadic", "tonal"]))]
    palette = [[round(float(c), 6) for c in base_color[:3]]]
    for k in range(int(rng.integers(1, 4))):
        hue = (h + offsets[k]) % 1.0
        sat = float(np.clip(s * rng.uniform(0.5, 1.2), 0, 1))
        val = float(np.clip(v * rng.uniform(0.4, 1.3), 0.05, 1))
        palette.append([round(float(c), 6) for c in colorsys.hsv_to_rgb(hue, sat, val)])
    return palette


def draw_texture(
    rng: np.random.Generator,
    base_color: list[float],
    families: tuple[str, ...],
    scale_m: tuple[float, float],
) -> dict[str, Any]:
    """One procedural texture's stored values, its palette built around ``base_color``."""
    return {
        "family": str(rng.choice(list(families))),
        "palette": draw_palette(rng, base_color),
        "seed": int(rng.integers(2**31)),
        "scale_m": round(float(rng.uniform(*scale_m)), 6),
        "rotation_deg": round(float(rng.uniform(0.0, 360.0)), 6),
    }


def tile_key(values: dict[str, Any]) -> str:
    """What the tile depends on (not its scale or rotation on a surface), as a cache key."""
    return json.dumps(
        {k: v for k, v in values.items() if k not in ("scale_m", "rotation_deg")}, sort_keys=True
    )


def texture_tile(values: dict[str, Any]) -> np.ndarray:
    """The texture's tile, (H, W, 3) uint8 sRGB, rebuilt from its stored values (cached: the
    same values give the same array object, which callers must not modify)."""
    return _tile(tile_key(values))


@functools.lru_cache(maxsize=256)
def _tile(key: str) -> np.ndarray:
    values = json.loads(key)
    if values["family"] == IMAGE_FAMILY:
        from datagen.assets.image_library import file_sha256, load_image

        if file_sha256(values["root"], values["path"]) != values["sha256"]:
            raise ValueError(
                f"{values['root']}/{values['path']}: not the picture the sample was made with "
                f"(its sha256 differs from the stored {values['sha256'][:12]}...)"
            )
        tile = load_image(values["root"], values["path"])
        if "crop" in values:  # drawn as a photograph is (samples made before: the whole picture)
            tile = cropped_and_jittered(tile, values)
    elif values["family"] == PHOTO_FAMILY:
        tile = photo_tile(values)
    else:
        tile = apply_palette(pattern(values["family"], values["seed"]), values["palette"])
    tile.flags.writeable = False
    return tile


def height_normal_map(values: dict[str, Any], strength: float = 2.0) -> np.ndarray:
    """A tangent-space normal map from the tile's brightness read as height (bright is high):
    (H, W, 3) uint8, ``(n + 1) / 2`` encoded, periodic like the tile."""
    height = texture_tile(values).astype(float).mean(axis=2) / 255.0
    dx = (np.roll(height, -1, 1) - np.roll(height, 1, 1)) * strength
    dy = (np.roll(height, -1, 0) - np.roll(height, 1, 0)) * strength
    normal = np.stack([-dx, -dy, np.ones_like(height)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return np.round((normal + 1) * 127.5).astype(np.uint8)


def surface_uv(uv_m: np.ndarray, values: dict[str, Any]) -> np.ndarray:
    """Texture coordinates (N, 2) float32 of points whose surface coordinates are ``uv_m``
    (metres): turned by ``rotation_deg`` and divided by ``scale_m`` (one repeat per scale; a
    picture repeats every ``scale_m`` across and ``scale_m * aspect`` down, keeping its shape)."""
    angle = np.deg2rad(values["rotation_deg"])
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    repeat = np.array([values["scale_m"], values["scale_m"] * values.get("aspect", 1.0)])
    return (np.asarray(uv_m, float) @ rotation.T / repeat).astype(np.float32)


def photo_tile(values: dict[str, Any]) -> np.ndarray:
    """A library picture as its stored values draw it (:func:`cropped_and_jittered`)."""
    from datagen.library.catalogue import load_picture

    return cropped_and_jittered(load_picture(values["path"], values["sha256"]), values)


def cropped_and_jittered(image: np.ndarray, values: dict[str, Any]) -> np.ndarray:
    """``image`` (H, W, 3) uint8 sRGB as a picture's stored values draw it: cropped (``crop``:
    x0, y0, side as fractions), mirrored (``flip``), hue-rotated, saturation-scaled, then
    contrast about its mean and a brightness offset; (h, w, 3) uint8 sRGB."""
    height, width = image.shape[:2]
    x0, y0, side = values["crop"]
    rows = slice(round(y0 * height), max(round(y0 * height) + 1, round((y0 + side) * height)))
    cols = slice(round(x0 * width), max(round(x0 * width) + 1, round((x0 + side) * width)))
    crop = image[rows, cols][:, ::-1] if values["flip"] else image[rows, cols]
    hsv = cv2.cvtColor(np.ascontiguousarray(crop, np.float32) / 255.0, cv2.COLOR_RGB2HSV)
    hsv[..., 0] = (hsv[..., 0] + values["hue_deg"]) % 360.0  # float HSV: hue in degrees
    hsv[..., 1] = np.clip(hsv[..., 1] * values["saturation"], 0.0, 1.0)
    rgb = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)
    rgb = (rgb - rgb.mean()) * values["contrast"] + rgb.mean() + values["brightness"]
    return np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)
