"""Grasping scene: an arm (``robot.name``, the Panda by default) on a table before a tray of
procedurally generated objects.

World frame: z up, metres; the table top is at z = TABLE_TOP, the robot base stands on its
edge at negative x and the tray lies in front of it. Objects are dropped into the tray and
settled by physics before any camera renders.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sapien

from datagen.assets.shapes import ObjectGeometry
from datagen.assets.tabletop_layout import StaticPart, Workspace, static_parts
from datagen.config import BuildConfig
from datagen.config.robot import arm_workspace, robot_spec
from datagen.families.grasp_tabletop.values import draw_values, redrawn_drop_poses
from datagen.robot_specs import RobotSpec, wrist_mount
from datagen.scene_values.arm import ArmPose
from datagen.scene_values.material import Material
from datagen.sensing.cameras import add_camera
from datagen.worlds.arm_clearance import link_bodies, meets, part_bodies
from datagen.worlds.class_names import (
    CLASSES,
    DISTRACTOR_CLASS,
    GRIPPER_CLASS,
    WALL_CLASS,
)
from datagen.worlds.look_pose import look_qpos
from datagen.worlds.realise import (
    SOFT_LIGHT_SPOTS,
    add_background,
    add_distractors,
    add_objects,
    light_slots,
    lit_by_room,
    pad_lights,
    realise,
)
from datagen.worlds.robots import load_robot
from datagen.worlds.settle import settle
from datagen.worlds.surfaces import box_entity, render_material
from datagen.worlds.tray_targets import MAX_REDRAWS, TargetsOutsideTray, outside_tray

CLASS_ID = {name: i for i, name in enumerate(CLASSES)}
LOOK_CLEARANCE = 0.005  # metres between an object and the arm at its look pose


def load_arm(
    scene: sapien.Scene, spec: RobotSpec, max_triangles: int = 0
) -> sapien.physx.PhysxArticulation:
    """The arm of ``spec``, fixed base, from the process's parsed URDF (datagen.worlds.robots),
    drawn with at most ``max_triangles`` triangles (0: its own meshes)."""
    return load_robot(scene, spec.urdf_path(), fix_root_link=True, max_triangles=max_triangles)


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
    spec: RobotSpec
    workspace: Workspace
    # per_scene_id of every rendered entity that is not an object -> class name
    stuff: dict[int, str] = field(default_factory=dict)
    distractors: list[SceneObject] = field(default_factory=list)  # instance ids after objects


def _add_part(scene: sapien.Scene, part: StaticPart, material: Material) -> list[sapien.Entity]:
    """A part of the static geometry; the floor is SAPIEN's ground plane, drawn as its slab only
    when textured (texture coordinates), else by the plane itself (the slab's extent)."""
    name = "_".join(filter(None, (part.surface, part.name)))
    if part.surface != "floor":
        return [box_entity(scene, name, part.boxes, material, part.position)]
    if material.texture is None:
        drawn = render_material(material)
        return [scene.add_ground(0.0, render_material=drawn, render_half_size=part.boxes[0][0][:2])]
    ground = scene.add_ground(0.0, render=False)
    return [ground, box_entity(scene, name, part.boxes, material, part.position, collide=False)]


def _light_slots(config: BuildConfig) -> dict[str, int]:
    lighting, room = config.lighting, config.background
    soft_key = lighting.shadows and lighting.soft_shadow_probability > 0
    spots = max(lighting.lights[1] - 1, 0) + (SOFT_LIGHT_SPOTS if soft_key else 0)
    return light_slots(spots, room.room_lights[1] if room.enabled else 0)


def build_scene(
    config: BuildConfig,
    seed: int,
    index: int,
    attempt: int = 0,
    values: dict[str, Any] | None = None,
    arm: RobotSpec | None = None,
) -> GraspScene:
    """A fresh SAPIEN scene for sample ``index`` of the build, settled and ready to render, with
    every target in the tray and, with ``robot.pose: look``, the arm then moved to its look pose
    (the objects settle under the arm at its ready pose: dropped, they would meet the hand): a
    scene where a target is outside or the posed arm meets one is built again from re-drawn drop
    poses (``datagen.worlds.tray_targets``); raises TargetsOutsideTray after ``MAX_REDRAWS``.
    ``values``: the scene's drawn values (:func:`draw_values`; drawn here when None), ``arm``
    the configured arm, resolved once for the sample by the caller (else here)."""
    arm = arm or robot_spec(config.robot)
    ws = arm_workspace(arm)
    tray_floor_top, tray_inner_half = ws.tray_floor_top, ws.tray_inner_half
    params = values if values is not None else draw_values(config, seed, index, attempt, arm)
    redraws: list[dict[str, str]] = []
    while True:
        scene = construct_scene(config, params, arm)
        settle_scene(config, scene)
        outside = outside_tray(scene.objects, ws) or take_look_pose(scene)
        if not outside:
            return scene
        if len(redraws) == MAX_REDRAWS:
            raise TargetsOutsideTray(
                f"sample {index} (seed {seed}, attempt {attempt}): after {MAX_REDRAWS} re-draws, "
                + "; ".join(outside)
            )
        count = len(params["objects"])
        redraw = len(redraws) + 1
        stream, poses = redrawn_drop_poses(
            config, seed, index, redraw, count, tray_floor_top, tray_inner_half, attempt, arm
        )
        redraws = [*redraws, {"stream": stream, "why": "; ".join(outside)}]
        params = {**params, "drop_poses": poses, "redraws": redraws}


def take_look_pose(scene: GraspScene) -> list[str]:
    """Moves the arm of a settled scene to its look pose (``randomisation.robot.look``; nothing
    without one); one line per object its links then come within ``LOOK_CLEARANCE`` of."""
    values = scene.params["robot"]
    if values.look is None:
        return []
    base = np.add(scene.workspace.robot_base, scene.spec.mount)
    qpos = look_qpos(scene.spec, base, values.look, values.qpos)
    realise(ArmPose(tuple(qpos)), scene.robot, joint_names=scene.spec.joint_names)
    arm = link_bodies(scene.robot.get_links())
    return [
        f"object {obj.instance_id} ({obj.class_name}) meets the arm at its look pose"
        for obj in scene.objects
        if meets(arm, part_bodies(obj.geometry.parts, _pose(obj.entity)), LOOK_CLEARANCE)
    ]


def _pose(entity: sapien.Entity) -> np.ndarray:
    return np.asarray(entity.pose.to_transformation_matrix(), float)


def body(obj: SceneObject) -> sapien.physx.PhysxRigidDynamicComponent:
    return obj.entity.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)


def settle_scene(config: BuildConfig, scene: GraspScene) -> int:
    """Settles ``scene``'s objects (``datagen.worlds.settle``); returns the physics steps."""
    return settle(
        scene.scene,
        [body(o) for o in scene.objects],
        [float(np.max(o.geometry.obb_extents)) / 2 for o in scene.objects],
        scene.robot,
        max_steps=round(config.physics.settle_time / config.physics.timestep),
        settle_velocity=config.physics.settle_velocity,
    )


def construct_scene(
    config: BuildConfig, params: dict[str, Any], arm: RobotSpec | None = None
) -> GraspScene:
    """The scene described by ``params`` (the drawn values; objects at ``drop_poses``), not
    yet settled, with the configured arm (``arm``: resolved already, else here). Replay passes
    the stored values with the settled poses instead."""
    materials = params["materials"]
    scene = sapien.Scene()
    scene.set_timestep(config.physics.timestep)
    stuff: dict[int, str] = {}

    spec = arm or robot_spec(config.robot)
    ws = arm_workspace(spec)
    for part in static_parts(ws):
        for entity in _add_part(scene, part, materials[part.surface]):
            stuff[entity.per_scene_id] = part.surface
    for entity in add_background(scene, params.get("background")):  # none when it is off
        stuff[entity.per_scene_id] = WALL_CLASS

    robot = load_arm(scene, spec, config.render.robot_triangles)
    robot.set_root_pose(sapien.Pose(list(np.add(ws.robot_base, spec.mount))))
    realise(params["robot"], robot, joint_names=spec.joint_names)
    for link in robot.get_links():
        gripper = link.name in spec.gripper.links
        stuff[link.entity.per_scene_id] = GRIPPER_CLASS if gripper else "robot"

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
    lighting = lit_by_room(params["lighting"], params.get("background"))
    realise(lighting, scene, shadow_map_size=r.shadow_map_size)
    pad_lights(scene, _light_slots(config))

    workspace = add_camera(scene, "workspace", r.width, r.height, 1.0, r.near, r.far)
    realise(params["camera"], workspace)
    cameras = {"workspace": workspace}
    for name, values in params.get("extra_views", {}).items():  # render.views > 1
        cameras[name] = add_camera(scene, name, r.width, r.height, 1.0, r.near, r.far)
        realise(values, cameras[name])
    if r.wrist_camera:
        mount = wrist_mount(spec)
        link = next(link for link in robot.get_links() if link.name == mount.link)
        pose = sapien.Pose(list(mount.position), list(mount.quat_wxyz))
        fovy = np.deg2rad(mount.fovy_deg)
        cameras["wrist"] = add_camera(
            scene, "wrist", r.width, r.height, fovy, mount.near, r.far, link.entity, pose
        )
    return GraspScene(scene, cameras, objects, robot, params, spec, ws, stuff, distractors)
