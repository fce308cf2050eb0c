"""A tabletop scene's values, all drawn before anything is built: :func:`draw_scene`, each
value from its own (seed, index, name) stream with the shared randomisers; the world
(:mod:`datagen.families.grasp_tabletop.world`) builds what they describe."""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.config import BuildConfig
from datagen.config.robot import arm_workspace, robot_spec
from datagen.randomisers.background import draw_background
from datagen.randomisers.camera import draw_camera, draw_extra_view, extra_view_name
from datagen.randomisers.distractors import draw_distractors, draw_flying
from datagen.randomisers.lighting import draw_lighting
from datagen.randomisers.materials import class_free_colours, draw_materials
from datagen.randomisers.objects import draw_objects
from datagen.randomisers.photos import add_photo_backdrops, add_photo_surfaces
from datagen.randomisers.poses import draw_drop_poses
from datagen.randomisers.robot import draw_robot
from datagen.randomisers.textures import add_textures
from datagen.randomisers.workspace import scaled_to_robot
from datagen.robot_specs import RobotSpec
from datagen.seeding import sample_rng


def draw_scene(
    config: BuildConfig,
    seed: int,
    index: int,
    tray_floor_top: tuple[float, float, float],
    tray_inner_half: tuple[float, float],
    attempt: int = 0,
    arm: RobotSpec | None = None,
) -> dict[str, Any]:
    """All randomised values of one scene, by name (typed values: ``datagen.scene_values``);
    stored in the sample's metadata as ``as_json`` writes them. Objects drop into the tray
    whose floor's top centre is ``tray_floor_top`` (metres), within ``tray_inner_half``; lights
    aim there. The workspace camera is ``camera``; the extra views of ``render.views`` > 1 are
    under ``extra_views`` by name (``view1``, ...), each from its own stream. ``arm``: the
    configured arm, resolved once per sample by the caller (else here)."""

    def rng(name: str):
        return sample_rng(seed, index, name, attempt)

    arm = arm or robot_spec(config.robot)
    config = scaled_to_robot(config, arm)  # a small arm's scene; the config itself for scale 1
    ws = arm_workspace(arm)
    objects = draw_objects(rng("objects"), config.objects)
    drops = draw_drop_poses(
        rng("drop_poses"), config.objects, len(objects), tray_floor_top, tray_inner_half
    )
    dropped_at = np.mean([pose["position"][:2] for pose in drops], axis=0)
    params: dict[str, Any] = {
        "objects": objects,
        "drop_poses": drops,
        # textures come from a stream of their own: probability 0 leaves the materials as they were
        "materials": add_textures(
            rng("textures"),
            config.materials,
            draw_materials(rng("materials"), config.materials, len(objects)),
            config.photos,
        ),
        "lighting": draw_lighting(rng("lighting"), config.lighting, tray_floor_top),
        "camera": draw_camera(rng("camera"), config.camera),
        "robot": draw_robot(rng("robot"), config.robot, ws, dropped_at, arm),
    }
    if config.background.enabled:  # absent when off: the scene stays as it was
        params["background"] = draw_background(
            rng("background"), config.background, config.materials, tray_floor_top, config.photos
        )
    if config.photos.enabled:  # photographs over what was drawn, from streams of their own
        params["materials"] = add_photo_surfaces(
            rng("photos.surfaces"), config.photos, params["materials"]
        )
        if "background" in params:
            params["background"] = add_photo_backdrops(
                rng("photos.backdrops"), config.photos, params["background"]
            )
    # with materials.class_independent_probability: one colour range for every class
    params = class_free_colours(rng("colours"), config.materials, params)
    if config.distractors.enabled:  # absent when off: the scene stays as it was
        room = params["background"]["room"] if "background" in params else None
        camera = params["camera"]
        params["distractors"] = draw_distractors(
            rng("distractors"),
            config.distractors,
            config.materials,
            camera,
            room,
            ws,
            config.photos,
        )
        params["distractors"] += draw_flying(  # after the others; none for flying [0, 0]
            rng("distractors.flying"),
            config.distractors,
            config.materials,
            config.photos,
            params["camera"],
            room,
            ws,
            config.render.width / config.render.height,
            wrist_view=params["robot"].look is not None,
        )
    if config.render.views > 1:  # absent for one view: a one-view sample stays as it was
        names = [extra_view_name(k) for k in range(1, config.render.views)]
        params["extra_views"] = {
            name: draw_extra_view(rng(f"camera.{name}"), config.camera) for name in names
        }
    return params


def draw_values(
    config: BuildConfig, seed: int, index: int, attempt: int = 0, arm: RobotSpec | None = None
) -> dict[str, Any]:
    """:func:`draw_scene` for the tray of ``arm``'s workspace (the configured arm's when None)."""
    arm = arm or robot_spec(config.robot)
    ws = arm_workspace(arm)
    return draw_scene(config, seed, index, ws.tray_floor_top, ws.tray_inner_half, attempt, arm)


def redrawn_drop_poses(
    config: BuildConfig,
    seed: int,
    index: int,
    redraw: int,
    count: int,
    tray_floor_top: tuple[float, float, float],
    tray_inner_half: tuple[float, float],
    attempt: int = 0,
    arm: RobotSpec | None = None,
) -> tuple[str, list[dict[str, Any]]]:
    """Re-draw ``redraw`` (1, 2, ...) of the drop poses, when a target settled outside the tray:
    (the stream's name, the poses) from stream ``drop_poses.redraw<k>``, still a function of
    (seed, index, attempt) alone."""
    stream = f"drop_poses.redraw{redraw}"
    rng = sample_rng(seed, index, stream, attempt)
    objects = scaled_to_robot(config, arm or robot_spec(config.robot)).objects
    return stream, draw_drop_poses(rng, objects, count, tray_floor_top, tray_inner_half)
