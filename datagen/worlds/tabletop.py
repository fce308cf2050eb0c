"""Grasping scene: ManiSkill's Panda on a table before a tray of procedurally generated objects.

World frame: z up, metres; the table top is at z = TABLE_TOP, the robot base stands on its
edge at negative x and the tray lies in front of it. Objects are dropped into the tray and
settled by physics before any camera renders.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import sapien

from datagen.assets.shapes import ObjectGeometry
from datagen.assets.tabletop_layout import (
    ROBOT_BASE,
    TABLE_HALF,
    TABLE_TOP,
    TRAY_CENTRE,
    TRAY_FLOOR,
    TRAY_INNER_HALF,
    tray_boxes,
)
from datagen.config import BuildConfig
from datagen.config.sections import SHAPE_FAMILIES
from datagen.randomisers import sample_scene
from datagen.randomisers.background import add_background, lit_by_room
from datagen.randomisers.camera import apply_camera
from datagen.randomisers.distractors import add_distractors
from datagen.randomisers.lighting import apply_lighting
from datagen.randomisers.materials import render_material
from datagen.randomisers.objects import add_objects
from datagen.randomisers.robot import apply_robot
from datagen.randomisers.textures import surface_entity
from datagen.worlds.robots import PANDA, load_robot, maniskill_asset
from datagen.worlds.settle import settle

# Semantic classes: 0 is background (nothing rendered), object classes are shape families,
# then the distractors (objects that are not grasp targets), whatever their shape, then the
# backdrop walls and ceiling (background.enabled). The new classes come last so the ids of the
# earlier ones stay what they were; both are classes whether or not a build has any, so ids are
# the same across configs (docs/dataset-format.md).
STUFF_CLASSES = ("background", "floor", "table", "tray", "robot")
DISTRACTOR_CLASS = "distractor"
WALL_CLASS = "wall"
CLASSES = (*STUFF_CLASSES, *SHAPE_FAMILIES, DISTRACTOR_CLASS, WALL_CLASS)
CLASS_ID = {name: i for i, name in enumerate(CLASSES)}
FLOOR_HALF = 10.0  # metres: half the side of the drawn floor (as SAPIEN's ground)


def grasp_classes(config: BuildConfig) -> tuple[str, ...]:
    """Semantic classes of a build: the shape families, or the class folders of the user's
    meshes (``objects.source: folder``), after the surfaces."""
    if config.objects.source == "folder":
        from datagen.assets.mesh_library import load_library

        meshes = load_library(config.objects.assets_dir).classes
        return (*STUFF_CLASSES, *meshes, DISTRACTOR_CLASS, WALL_CLASS)
    return CLASSES


# Wrist camera on the Panda hand, from ManiSkill's panda_wristcam (pose in the hand frame).
WRIST_CAMERA_POSE = sapien.Pose([0.0464982, -0.0200011, 0.0360011], [0, 0.70710678, 0, 0.70710678])


def panda_urdf() -> Path:
    return maniskill_asset(PANDA)


def load_panda(scene: sapien.Scene) -> sapien.physx.PhysxArticulation:
    """The Panda, fixed base, from the process's parsed URDF (datagen.worlds.robots)."""
    return load_robot(scene, PANDA, fix_root_link=True)


@dataclass
class SceneObject:
    instance_id: int  # 1..K in the instance map
    class_name: str
    entity: sapien.Entity
    geometry: ObjectGeometry
    spec: dict[str, Any]
    role: str = "target"  # or "distractor": never a grasp target, class DISTRACTOR_CLASS


@dataclass
class GraspScene:
    scene: sapien.Scene
    cameras: dict[str, sapien.render.RenderCameraComponent]
    objects: list[SceneObject]
    robot: sapien.physx.PhysxArticulation
    params: dict[str, Any]
    # per_scene_id of every rendered entity that is not an object -> class name
    stuff: dict[int, str] = field(default_factory=dict)
    distractors: list[SceneObject] = field(default_factory=list)  # instance ids after objects


def _static_box(scene, name, half_size, position, material_values) -> sapien.Entity:
    if "texture" in material_values:
        entity = surface_entity(scene, name, [(half_size, [0, 0, 0])], material_values)
        entity.set_pose(sapien.Pose(position))
        return entity
    builder = scene.create_actor_builder()
    builder.add_box_collision(half_size=half_size)
    builder.add_box_visual(half_size=half_size, material=render_material(material_values))
    entity = builder.build_static(name=name)
    entity.set_pose(sapien.Pose(position))
    return entity


def _add_table(scene, material) -> list[sapien.Entity]:
    thickness = 0.03
    parts = [
        _static_box(
            scene,
            "table",
            [*TABLE_HALF, thickness / 2],
            [0, 0, TABLE_TOP - thickness / 2],
            material,
        )
    ]
    leg = (TABLE_TOP - thickness) / 2
    for sx in (-1, 1):
        for sy in (-1, 1):
            position = [sx * (TABLE_HALF[0] - 0.05), sy * (TABLE_HALF[1] - 0.05), leg]
            parts.append(_static_box(scene, "table_leg", [0.025, 0.025, leg], position, material))
    return parts


def _add_tray(scene, material) -> sapien.Entity:
    if "texture" in material:
        tray = surface_entity(scene, "tray", list(tray_boxes()), material)
        tray.set_pose(sapien.Pose(TRAY_CENTRE))
        return tray
    builder = scene.create_actor_builder()
    mat = render_material(material)
    for half_size, offset in tray_boxes():
        builder.add_box_collision(sapien.Pose(offset), half_size=half_size)
        builder.add_box_visual(sapien.Pose(offset), half_size=half_size, material=mat)
    tray = builder.build_static(name="tray")
    tray.set_pose(sapien.Pose(TRAY_CENTRE))
    return tray


def _add_floor(scene, material) -> list[sapien.Entity]:
    """The ground plane; a textured floor is drawn as a big thin box (texture coordinates)."""
    if "texture" not in material:
        return [scene.add_ground(0.0, render_material=render_material(material))]
    ground = scene.add_ground(0.0, render=False)
    half = [FLOOR_HALF, FLOOR_HALF, 0.005]
    floor = surface_entity(scene, "floor", [(half, [0, 0, -0.005])], material, collide=False)
    return [ground, floor]


def build_scene(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> GraspScene:
    """A fresh SAPIEN scene for sample ``index`` of the build, settled and ready to render."""
    tray_floor_top = (TRAY_CENTRE[0], TRAY_CENTRE[1], TRAY_CENTRE[2] + TRAY_FLOOR)
    params = sample_scene(config, seed, index, tray_floor_top, TRAY_INNER_HALF, attempt)
    scene = construct_scene(config, params)
    settle(
        scene.scene,
        [
            o.entity.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
            for o in scene.objects
        ],
        [float(np.max(o.geometry.obb_extents)) / 2 for o in scene.objects],
        scene.robot,
        max_steps=round(config.physics.settle_time / config.physics.timestep),
        settle_velocity=config.physics.settle_velocity,
    )
    return scene


def construct_scene(config: BuildConfig, params: dict[str, Any]) -> GraspScene:
    """The scene described by ``params`` (the sampled values; objects at ``drop_poses``), not
    yet settled. Replay passes the stored values with the settled poses instead."""
    materials = params["materials"]
    scene = sapien.Scene()
    scene.set_timestep(config.physics.timestep)
    stuff: dict[int, str] = {}

    for entity in _add_floor(scene, materials["floor"]):
        stuff[entity.per_scene_id] = "floor"
    for entity in _add_table(scene, materials["table"]):
        stuff[entity.per_scene_id] = "table"
    stuff[_add_tray(scene, materials["tray"]).per_scene_id] = "tray"
    for entity in add_background(scene, params.get("background")):  # none when it is off
        stuff[entity.per_scene_id] = WALL_CLASS

    robot = load_panda(scene)
    robot.set_root_pose(sapien.Pose(ROBOT_BASE))
    apply_robot(robot, params["robot"])
    for link in robot.get_links():
        stuff[link.entity.per_scene_id] = "robot"

    added = add_objects(scene, params["objects"], params["drop_poses"], materials["objects"])
    objects = [
        SceneObject(i + 1, spec["shape"]["family"], entity, geometry, spec)
        for i, ((entity, geometry), spec) in enumerate(zip(added, params["objects"], strict=True))
    ]
    specs = params.get("distractors", [])  # absent when distractors are off
    distractors = [
        SceneObject(len(objects) + i + 1, DISTRACTOR_CLASS, entity, geometry, spec, "distractor")
        for i, ((entity, geometry), spec) in enumerate(
            zip(add_distractors(scene, specs), specs, strict=True)
        )
    ]
    r = config.render
    apply_lighting(
        scene, lit_by_room(params["lighting"], params.get("background")), r.shadow_map_size
    )

    workspace = scene.add_camera("workspace", r.width, r.height, 1.0, r.near, r.far)
    apply_camera(workspace, params["camera"])
    cameras = {"workspace": workspace}
    for name, values in params.get("extra_views", {}).items():  # render.views > 1
        cameras[name] = scene.add_camera(name, r.width, r.height, 1.0, r.near, r.far)
        apply_camera(cameras[name], values)
    if r.wrist_camera:
        hand = next(link for link in robot.get_links() if link.name == "panda_hand")
        cameras["wrist"] = scene.add_mounted_camera(
            "wrist", hand.entity, WRIST_CAMERA_POSE, r.width, r.height, np.deg2rad(70), 0.01, r.far
        )
    return GraspScene(scene, cameras, objects, robot, params, stuff, distractors)
