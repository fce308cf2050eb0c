"""Randomised appearance of a navigation scene: materials of walls, floor, doors and obstacles,
wall and obstacle heights, lighting over the whole floor plan, and Fetch's onboard camera (torso
lift = height, head tilt = pitch, field of view). The floor plan itself is drawn by
``datagen.floorplans.layouts`` from its own stream."""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.config import BuildConfig
from datagen.floorplans.grid import Layout
from datagen.randomisers.materials import draw_marker_material, random_material
from datagen.randomisers.room_lighting import draw_nav_lighting
from datagen.randomisers.textures import texture_surfaces
from datagen.registries import GROUND_ROBOTS
from datagen.registry import resolve
from datagen.scene_values.rounding import uniform
from datagen.seeding import sample_rng

# HSV value ranges that keep rooms plausible; obstacles use the config's full colour range.
_SURFACE_VALUE = {"floor": (0.2, 0.75), "walls": (0.5, 0.95), "doors": (0.3, 0.8)}
OBSTACLE_SHAPES = ("box", "cylinder")
TEXTURED_SURFACES = ("floor", "walls", "doors")  # boxes: texture coordinates by box mapping


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
    out["goal_marker"] = draw_marker_material(rng)
    return out


def draw_nav_scene(
    config: BuildConfig, seed: int, index: int, layout: Layout, attempt: int = 0
) -> dict[str, Any]:
    """All randomised appearance values of one episode; stored in its metadata."""
    nav = config.navigation
    geometry_rng = sample_rng(seed, index, "nav_geometry", attempt)
    wall_height = uniform(geometry_rng, nav.wall_height)
    obstacles = [
        {
            "shape": str(geometry_rng.choice(OBSTACLE_SHAPES)),
            "height": uniform(geometry_rng, nav.obstacle_height),
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
        "torso_lift": uniform(camera_rng, nav.torso_lift),
        "pitch_deg": uniform(camera_rng, nav.camera_pitch_deg),
        "fovy_deg": uniform(camera_rng, nav.camera_fovy_deg),
    }
    fleet = {}
    if nav.robots > 1:  # the other robots' cameras, from a stream of their own
        fleet_rng = sample_rng(seed, index, "nav_fleet_cameras", attempt)
        others = [
            {
                name: uniform(fleet_rng, bounds)
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
        "door_top": round(min(wall_height - 0.1, uniform(geometry_rng, (1.95, 2.15))), 6),
        "obstacles": obstacles,
        # textures from a stream of their own: probability 0 leaves the materials as they were
        "materials": materials,
        "lighting": draw_nav_lighting(
            sample_rng(seed, index, "nav_lighting", attempt), config, layout, wall_height
        ),
        "camera": camera,
    } | fleet
