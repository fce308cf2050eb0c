"""Object randomiser: count, shape family, dimensions, density, friction, restitution."""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.config.sections import HOUSEHOLD_FAMILIES, ObjectsConfig
from datagen.geometry import random_quaternion
from datagen.randomisers.household_parts import draw_household_parts


def _uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(rng.uniform(bounds[0], bounds[1]))


def _convex_points(rng: np.random.Generator, semi_axes: np.ndarray, n: int) -> list[list[float]]:
    directions = rng.normal(size=(n, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    radii = rng.uniform(0.6, 1.0, size=(n, 1))
    return np.round(directions * radii * semi_axes, 6).tolist()


def draw_shape(rng: np.random.Generator, family: str, size: float) -> dict[str, Any]:
    """Shape parameters (metres) for one object whose largest extent is about ``size``."""
    half = size / 2
    if family == "box":
        parts = [{"kind": "box", "extents": (rng.uniform(0.35, 1.0, 3) * size).round(6).tolist()}]
    elif family == "cylinder":
        radius = half * rng.uniform(0.35, 0.8)
        parts = [
            {
                "kind": "cylinder",
                "radius": round(radius, 6),
                "height": round(size * rng.uniform(0.5, 1.0), 6),
            }
        ]
    elif family == "sphere":
        parts = [{"kind": "sphere", "radius": round(half * rng.uniform(0.5, 0.9), 6)}]
    elif family == "capsule":
        radius = half * rng.uniform(0.25, 0.45)
        parts = [
            {"kind": "capsule", "radius": round(radius, 6), "height": round(size - 2 * radius, 6)}
        ]
    elif family == "convex":
        semi_axes = rng.uniform(0.4, 1.0, 3) * half
        parts = [
            {"kind": "convex", "points": _convex_points(rng, semi_axes, int(rng.integers(8, 20)))}
        ]
    elif family == "compound":
        parts = []
        for _ in range(int(rng.integers(2, 4))):
            kind = str(rng.choice(["box", "cylinder", "convex"]))
            sub = draw_shape(rng, kind, size * 0.55)["parts"][0]
            sub["offset"] = (rng.uniform(-0.5, 0.5, 3) * half * 0.6).round(6).tolist()
            sub["quat_wxyz"] = random_quaternion(rng)
            parts.append(sub)
    elif family in HOUSEHOLD_FAMILIES:
        parts = draw_household_parts(rng, family, size)
    else:
        raise ValueError(f"unknown shape family {family!r}")
    return {"family": family, "parts": parts}


def draw_asset_shape(rng: np.random.Generator, assets_dir: str, size: float) -> dict[str, Any]:
    """A user mesh (``objects.source: folder``), scaled so its largest extent is ``size``; the
    family is its class folder. The convex parts are stored with the sample, so the collision
    shape can be rebuilt from the metadata alone; the visual mesh is read from ``asset.path``."""
    from datagen.assets.mesh_library import load_library

    library = load_library(assets_dir)
    asset = library.assets[int(rng.integers(len(library.assets)))]
    return {
        "family": asset.class_name,
        "asset": {"root": assets_dir, "path": asset.path, "sha256": asset.sha256, "scale": size},
        "parts": [
            {"kind": "convex", "points": np.round(part * size, 6).tolist()} for part in asset.parts
        ],
    }


def draw_objects(rng: np.random.Generator, cfg: ObjectsConfig) -> list[dict[str, Any]]:
    count = int(rng.integers(cfg.count[0], cfg.count[1] + 1))
    objects = []
    for _ in range(count):
        if cfg.source == "folder":
            shape = draw_asset_shape(rng, cfg.assets_dir, _uniform(rng, cfg.size))
        else:
            family = str(rng.choice(list(cfg.families)))
            shape = draw_shape(rng, family, _uniform(rng, cfg.size))
        objects.append(
            {
                "shape": shape,
                "density": _uniform(rng, cfg.density),
                "friction": _uniform(rng, cfg.friction),
                "restitution": _uniform(rng, cfg.restitution),
            }
        )
    return objects
