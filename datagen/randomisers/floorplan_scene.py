"""Randomised appearance of a navigation scene: materials of walls, floor, doors and obstacles,
wall and obstacle heights, lighting over the whole floor plan, and Fetch's onboard camera (torso
lift = height, head tilt = pitch, field of view). The floor plan itself is drawn by
``datagen.navigation.layouts`` from its own stream."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import ndimage

from datagen.config import BuildConfig
from datagen.navigation.grid import Layout
from datagen.randomisers.lighting import light_direction
from datagen.randomisers.materials import random_colour, random_material
from datagen.randomisers.textures import texture_surfaces
from datagen.registries import GROUND_ROBOTS
from datagen.registry import resolve
from datagen.scene_values.lighting import Light, Lighting
from datagen.seeding import sample_rng

# HSV value ranges that keep rooms plausible; obstacles use the config's full colour range.
_SURFACE_VALUE = {"floor": (0.2, 0.75), "walls": (0.5, 0.95), "doors": (0.3, 0.8)}
OBSTACLE_SHAPES = ("box", "cylinder")
TEXTURED_SURFACES = ("floor", "walls", "doors")  # boxes: texture coordinates by box mapping
CEILING_LIGHT_BELOW_TOP = 0.2  # metres below the top of the walls
LAMP_CLEARANCE = 0.8  # metres


def _u(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return round(float(rng.uniform(*bounds)), 6)


def car_paint(rng: np.random.Generator, config: BuildConfig) -> dict[str, Any]:
    """The car's body, wheels and mast."""
    return {
        part: random_material(rng, config.materials, config.materials.saturation, value)
        for part, value in (("body", (0.4, 1.0)), ("wheels", (0.05, 0.2)), ("mast", (0.1, 0.4)))
    }


def draw_nav_materials(rng, config: BuildConfig, obstacles: int) -> dict[str, Any]:
    cfg = config.materials
    out: dict[str, Any] = {
        name: random_material(rng, cfg, (0.0, 0.6), value) for name, value in _SURFACE_VALUE.items()
    }
    out["obstacles"] = [
        random_material(rng, cfg, cfg.saturation, cfg.value) for _ in range(obstacles)
    ]
    goal = {
        "base_color": random_colour(rng, (0.8, 1.0), (0.8, 1.0)),
        "roughness": 0.5,
        "metallic": 0.0,
    }
    out["goal_marker"] = goal
    return out


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
        intensity = _u(rng, cfg.intensity)
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
        ambient=_u(rng, cfg.ambient),
        lights=tuple(lights),
        shadow_centre=(round(width / 2, 4), round(depth / 2, 4), round(top / 2, 4)),
        shadow_half_extent=round(max(width, depth) / 2 + 0.5, 4),
    )


def draw_nav_scene(
    config: BuildConfig, seed: int, index: int, layout: Layout, attempt: int = 0
) -> dict[str, Any]:
    """All randomised appearance values of one episode; stored in its metadata."""
    nav = config.navigation
    geometry_rng = sample_rng(seed, index, "nav_geometry", attempt)
    wall_height = _u(geometry_rng, nav.wall_height)
    obstacles = [
        {
            "shape": str(geometry_rng.choice(OBSTACLE_SHAPES)),
            "height": _u(geometry_rng, nav.obstacle_height),
        }
        for _ in layout.obstacles
    ]
    camera_rng = sample_rng(seed, index, "nav_camera", attempt)
    materials = texture_surfaces(
        sample_rng(seed, index, "nav_textures", attempt),
        config.materials,
        draw_nav_materials(
            sample_rng(seed, index, "nav_materials", attempt), config, len(obstacles)
        ),
        TEXTURED_SURFACES,
        config.photos,
    )
    robot = GROUND_ROBOTS[nav.robot]
    if robot.paint:  # from a stream of its own: the other robots' episodes keep their values
        paint_rng = sample_rng(seed, index, f"nav_{robot.name}", attempt)
        materials[robot.name] = resolve(robot.paint)(paint_rng, config)
    camera = {
        "torso_lift": _u(camera_rng, nav.torso_lift),
        "pitch_deg": _u(camera_rng, nav.camera_pitch_deg),
        "fovy_deg": _u(camera_rng, nav.camera_fovy_deg),
    }
    fleet = {}
    if nav.robots > 1:  # the other robots' cameras, from a stream of their own
        fleet_rng = sample_rng(seed, index, "nav_fleet_cameras", attempt)
        others = [
            {
                name: _u(fleet_rng, bounds)
                for name, bounds in (
                    ("torso_lift", nav.torso_lift),
                    ("pitch_deg", nav.camera_pitch_deg),
                    ("fovy_deg", nav.camera_fovy_deg),
                )
            }
            for _ in range(nav.robots - 1)
        ]
        fleet = {"cameras": [camera, *others]}
    return {
        "wall_height": wall_height,
        "door_top": round(min(wall_height - 0.1, _u(geometry_rng, (1.95, 2.15))), 6),
        "obstacles": obstacles,
        # textures from a stream of their own: probability 0 leaves the materials as they were
        "materials": materials,
        "lighting": draw_nav_lighting(
            sample_rng(seed, index, "nav_lighting", attempt), config, layout, wall_height
        ),
        "camera": camera,
    } | fleet
