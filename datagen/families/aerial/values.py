"""Randomised appearance of an aerial episode: materials of the floor, walls, ceiling and each kind
of obstacle, the drones' colours, the lighting over the volume, and each drone's cameras (forward
tilt and field of view, the downward camera's field of view; a stereo pair's right camera has the
forward one's values, ``aerial.stereo_baseline`` to its right: nothing of its own is drawn). The
volume and the flights are drawn by :mod:`datagen.families.aerial.episode` from streams of their own.

Streams: ``aerial_materials``, ``aerial_textures``, ``nav_lighting`` (as a ground episode's),
``aerial_cameras``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.config import BuildConfig
from datagen.floorplans.grid import Layout
from datagen.randomisers.materials import draw_marker_material, random_material
from datagen.randomisers.room_lighting import draw_nav_lighting
from datagen.randomisers.textures import texture_surfaces
from datagen.registries import AIRFRAMES
from datagen.scene_values.rounding import uniform
from datagen.seeding import sample_rng

SURFACES = {"floor": (0.2, 0.75), "walls": (0.5, 0.95), "ceiling": (0.6, 0.95)}  # HSV value
OBSTACLE_KINDS = ("obstacle", "pillar", "beam", "hanging", "screen")
TEXTURED = ("floor", "walls", "ceiling", *OBSTACLE_KINDS)


def _cameras(rng: np.random.Generator, cfg) -> dict[str, Any]:
    forward = {
        "fovy_deg": uniform(rng, cfg.camera_fovy_deg),
        "pitch_deg": uniform(rng, cfg.camera_pitch_deg),
        # the mount on the pod's face, left and up, fractions of quadrotor.MOUNT_SHIFT
        "shift": [uniform(rng, (-1.0, 1.0)), uniform(rng, (-1.0, 1.0))],
    }
    return {"forward": forward, "down": {"fovy_deg": uniform(rng, cfg.down_fovy_deg)}}


def draw_aerial_scene(
    config: BuildConfig,
    seed: int,
    index: int,
    layout: Layout,
    height: float,
    drones: int,
    attempt: int = 0,
) -> dict[str, Any]:
    """Every randomised appearance value of one episode; stored in its metadata."""
    cfg, materials_cfg = config.aerial, config.materials
    rng = sample_rng(seed, index, "aerial_materials", attempt)
    materials: dict[str, Any] = {
        name: random_material(rng, materials_cfg, (0.0, 0.6), value)
        for name, value in SURFACES.items()
    }
    for kind in OBSTACLE_KINDS:
        materials[kind] = random_material(
            rng, materials_cfg, materials_cfg.saturation, materials_cfg.value
        )
    materials["goal_marker"] = draw_marker_material(rng)
    drone_materials = [
        {
            part: random_material(rng, materials_cfg, (0.0, 0.9), value)
            for part, value in AIRFRAMES[cfg.airframe].paint
        }
        for _ in range(drones)
    ]
    cameras_rng = sample_rng(seed, index, "aerial_cameras", attempt)
    cameras = [_cameras(cameras_rng, cfg) for _ in range(drones)]
    return {
        "materials": texture_surfaces(
            sample_rng(seed, index, "aerial_textures", attempt),
            materials_cfg,
            materials,
            TEXTURED,
            config.photos,
        ),
        "drones": drone_materials,
        "lighting": draw_nav_lighting(
            sample_rng(seed, index, "nav_lighting", attempt), config, layout, height
        ),
        "cameras": cameras,
    }
