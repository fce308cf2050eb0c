"""Domain randomisation. Each randomiser is a pure sampler (rng in, JSON values out) plus an
apply step; :func:`sample_scene` draws them all, each from its own (seed, index, name) stream."""

from __future__ import annotations

from typing import Any

from datagen.config import BuildConfig
from datagen.randomisers.camera import sample_camera
from datagen.randomisers.lighting import sample_lighting
from datagen.randomisers.materials import sample_materials
from datagen.randomisers.objects import sample_objects
from datagen.randomisers.poses import sample_drop_poses
from datagen.randomisers.robot import sample_robot
from datagen.seeding import sample_rng


def sample_scene(
    config: BuildConfig,
    seed: int,
    index: int,
    tray_centre: tuple[float, float, float],
    tray_inner_half: tuple[float, float],
    attempt: int = 0,
) -> dict[str, Any]:
    """All randomised values of one scene; stored verbatim in the sample's metadata."""

    def rng(name: str):
        return sample_rng(seed, index, name, attempt)

    objects = sample_objects(rng("objects"), config.objects)
    return {
        "objects": objects,
        "drop_poses": sample_drop_poses(
            rng("drop_poses"), config.objects, len(objects), tray_centre, tray_inner_half
        ),
        "materials": sample_materials(rng("materials"), config.materials, len(objects)),
        "lighting": sample_lighting(rng("lighting"), config.lighting, tray_centre),
        "camera": sample_camera(rng("camera"), config.camera),
        "robot": sample_robot(rng("robot"), config.robot),
    }
