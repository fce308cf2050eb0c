"""Navigation scene: a floor plan from ``datagen.floorplans`` built in SAPIEN, with ManiSkill's
Fetch as the mobile robot and an RGB-D camera on its head.

World frame: z up, metres; the floor plan's grid origin (see ``datagen.floorplans``) is the world
origin and the floor top is z = 0. Fetch's base is driven through its three virtual root joints
(x, y, yaw) to each pose of the expert trajectory; nothing else moves, so no physics is stepped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import sapien

from datagen.config import BuildConfig
from datagen.families.navigation.episode import Episode
from datagen.floorplans.grid import Layout
from datagen.registries import GROUND_ROBOTS
from datagen.registry import resolve
from datagen.robot_specs import maniskill_asset
from datagen.sensing.cameras import add_camera
from datagen.worlds.class_names import NAV_CLASSES
from datagen.worlds.realise import light_slots, pad_lights, realise
from datagen.worlds.robots import FETCH, load_robot
from datagen.worlds.surfaces import box_entity, render_material
from datagen.worlds.things import Thing, rect_box

NAV_CLASS_ID = {name: i for i, name in enumerate(NAV_CLASSES)}


FLOOR_THICKNESS = 0.05  # metres
FLOOR_MARGIN = 1.0  # metres of floor beyond the floor plan on every side
THRESHOLD_HEIGHT = 0.004  # metres: the door's floor strip, drawn so doors show in the labels
GOAL_DISK = (0.22, 0.01)  # radius, thickness (metres)
GOAL_POLE = (0.025, 1.2)  # radius, height (metres)
# Fetch's standard tucked arm (keeps the arm out of the head camera's view), radians
TUCKED_ARM = {
    "shoulder_pan_joint": 1.32,
    "shoulder_lift_joint": 1.40,
    "upperarm_roll_joint": -0.2,
    "elbow_flex_joint": 1.72,
    "forearm_roll_joint": 0.0,
    "wrist_flex_joint": 1.66,
    "wrist_roll_joint": 0.0,
}
CAMERA_LINK = "head_camera_link"  # SAPIEN camera frame: x forward, y left, z up
BASE_JOINTS = ("root_x_axis_joint", "root_y_axis_joint", "root_z_rotation_joint")
# A z-axis cylinder from SAPIEN's x-axis one: 90 degrees about y.
_X_TO_Z = sapien.Pose(q=[math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0])


# Fetch (an articulation whose first joints are x, y, yaw), or a body with set_base (the car)
Robot = Any


@dataclass
class NavScene:
    scene: sapien.Scene
    cameras: list[sapien.render.RenderCameraComponent]  # each robot's camera
    robots: list[Robot]  # robot 0 first (the one robot of a single-robot episode)
    things: list[Thing]
    instance_lut: np.ndarray  # per_scene_id -> instance id (uint16); walls and floor are 0
    class_lut: np.ndarray  # per_scene_id -> semantic class id (uint8)

    @property
    def camera(self) -> sapien.render.RenderCameraComponent:
        return self.cameras[0]

    @property
    def robot(self) -> Robot:
        return self.robots[0]

    def set_base(self, x: float, y: float, yaw: float, steer: float = 0.0, k: int = 0) -> None:
        """Robot ``k`` at (x, y, yaw); a car's front wheels turned for ``steer`` (radians)."""
        robot = self.robots[k]
        if not isinstance(robot, sapien.physx.PhysxArticulation):
            robot.set_base(x, y, yaw, steer)
            return
        qpos = robot.get_qpos()
        qpos[:3] = (x, y, yaw)
        robot.set_qpos(qpos)

    def label_maps(self, entity_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ids = np.minimum(entity_ids, len(self.class_lut) - 1)  # ids beyond the tables: nothing
        return self.instance_lut[ids], self.class_lut[ids]


def _static(scene, name, material, cylinders=(), spheres=()) -> sapien.Entity:
    """A visual-only static entity. cylinders (z axis): (centre, radius, height); spheres:
    (centre, radius); metres."""
    builder = scene.create_actor_builder()
    for centre, radius, height in cylinders:
        pose = sapien.Pose(centre) * _X_TO_Z
        builder.add_cylinder_visual(pose, radius=radius, half_length=height / 2, material=material)
    for centre, radius in spheres:
        builder.add_sphere_visual(sapien.Pose(centre), radius=radius, material=material)
    return builder.build_static(name=name)


def _surface(scene, name, values, boxes) -> sapien.Entity:
    """A visual-only static entity of boxes (half size, centre; world metres)."""
    return box_entity(scene, name, boxes, values, collide=False)


def _walls_and_doors(scene, layout: Layout, values) -> tuple[list[sapien.Entity], list[Thing]]:
    h, top = values["wall_height"], values["door_top"]
    wall_material, door_material = values["materials"]["walls"], values["materials"]["doors"]
    walls = [
        _surface(scene, f"wall_{i}", wall_material, boxes=[rect_box(rect, 0.0, h)])
        for i, rect in enumerate(layout.walls)
    ]
    doors = []
    for i, rect in enumerate(layout.doors):
        lintel = rect_box(rect, top, h)
        threshold = rect_box(rect, 0.0, THRESHOLD_HEIGHT)
        entity = _surface(scene, f"door_{i}", door_material, boxes=[lintel, threshold])
        doors.append(Thing(0, "door", f"door_{i}", [entity]))
    return walls, doors


def _obstacles(scene, layout: Layout, values) -> list[Thing]:
    things = []
    specs = zip(
        layout.obstacles, values["obstacles"], values["materials"]["obstacles"], strict=True
    )
    for i, (rect, spec, material) in enumerate(specs):
        half, centre = rect_box(rect, 0.0, spec["height"])
        if spec["shape"] == "cylinder":  # inscribed in the footprint, so inside the occupied cells
            cylinder = (centre, min(half[:2]), spec["height"])
            entity = _static(scene, f"obstacle_{i}", render_material(material), [cylinder])
        else:
            entity = _surface(scene, f"obstacle_{i}", material, [(half, centre)])
        things.append(Thing(0, "obstacle", f"obstacle_{i}", [entity]))
    return things


def _goal_marker(scene, goal, values, name: str = "goal_marker") -> Thing:
    gx, gy = goal
    (disk_r, disk_t), (pole_r, pole_h) = GOAL_DISK, GOAL_POLE
    entity = _static(
        scene,
        name,
        render_material(values["materials"]["goal_marker"]),
        cylinders=[([gx, gy, disk_t / 2], disk_r, disk_t), ([gx, gy, pole_h / 2], pole_r, pole_h)],
        spheres=[([gx, gy, pole_h], 0.07)],
    )
    return Thing(0, "goal_marker", name, [entity])


def _fetch(
    scene: sapien.Scene, camera_values: dict[str, Any], max_triangles: int
) -> sapien.physx.PhysxArticulation:
    # parsed once per process
    robot = load_robot(scene, maniskill_asset(FETCH), True, max_triangles)
    targets = TUCKED_ARM | {
        "torso_lift_joint": camera_values["torso_lift"],
        "head_tilt_joint": math.radians(camera_values["pitch_deg"]),  # positive tilts down
    }
    qpos = np.zeros(robot.dof)
    for i, joint in enumerate(robot.get_active_joints()):
        qpos[i] = targets.get(joint.name, 0.0)
        lo, hi = joint.limits[0]
        if np.isfinite(lo) and not lo - 1e-6 <= qpos[i] <= hi + 1e-6:
            raise ValueError(f"Fetch joint {joint.name}: {qpos[i]} outside [{lo}, {hi}]")
    robot.set_qpos(qpos)
    names = [j.name for j in robot.get_active_joints()[:3]]
    if tuple(names) != BASE_JOINTS:
        raise RuntimeError(f"unexpected Fetch description: first joints are {names}")
    return robot


def build_nav_scene(config: BuildConfig, episode: Episode, values: dict[str, Any]) -> NavScene:
    """The scene of a single-robot episode."""
    return build_floorplan_scene(config, episode.layout, [episode.goal], [values["camera"]], values)


def _robot(config: BuildConfig, scene: sapien.Scene, cam: dict[str, Any], values, name: str):
    """The robot of ``navigation.robot`` (its record's ``body``), its labelled thing and its
    camera."""
    record = GROUND_ROBOTS[config.navigation.robot]
    body, entities, camera = resolve(record.body)(config, scene, cam, values)
    return body, Thing(0, record.label, name.replace("robot", record.name), entities), camera


def fetch_body(config: BuildConfig, scene: sapien.Scene, cam: dict[str, Any], values):
    """Fetch, its links and its head camera."""
    r = config.render
    fetch = _fetch(scene, cam, r.robot_triangles)
    head = next(link for link in fetch.get_links() if link.name == CAMERA_LINK)
    fovy = math.radians(cam["fovy_deg"])
    camera = add_camera(scene, "head", r.width, r.height, fovy, r.near, r.far, head.entity)
    return fetch, [link.entity for link in fetch.get_links()], camera


def build_floorplan_scene(
    config: BuildConfig,
    layout: Layout,
    goals: list,
    cameras: list[dict[str, Any]],
    values: dict[str, Any],
) -> NavScene:
    """The floor plan with one robot per entry of ``cameras`` (its camera's values) and a goal
    marker per goal. Instances: obstacles, doors, goal markers, robots, in that order."""
    scene = sapien.Scene()
    width, depth = layout.size_m
    half = [width / 2 + FLOOR_MARGIN, depth / 2 + FLOOR_MARGIN, FLOOR_THICKNESS / 2]
    floor = _surface(
        scene,
        "floor",
        values["materials"]["floor"],
        boxes=[(half, [width / 2, depth / 2, -FLOOR_THICKNESS / 2])],
    )
    walls, doors = _walls_and_doors(scene, layout, values)
    one = len(cameras) == 1
    things = [*_obstacles(scene, layout, values), *doors]
    for k, goal in enumerate(goals):
        things.append(
            _goal_marker(scene, goal, values, "goal_marker" if one else f"goal_marker_{k}")
        )
    robots, cams = [], []
    for k, cam in enumerate(cameras):
        robot, thing, camera = _robot(config, scene, cam, values, "robot" if one else f"robot_{k}")
        robots.append(robot)
        things.append(thing)
        cams.append(camera)
    for i, thing in enumerate(things):
        thing.instance_id = i + 1

    size = 1 + max(e.per_scene_id for t in things for e in t.entities)
    size = max(size, 1 + max(e.per_scene_id for e in [floor, *walls]))
    instance_lut = np.zeros(size, np.uint16)
    class_lut = np.zeros(size, np.uint8)
    class_lut[floor.per_scene_id] = NAV_CLASS_ID["floor"]
    for wall in walls:
        class_lut[wall.per_scene_id] = NAV_CLASS_ID["wall"]
    for thing in things:
        for entity in thing.entities:
            instance_lut[entity.per_scene_id] = thing.instance_id
            class_lut[entity.per_scene_id] = NAV_CLASS_ID[thing.class_name]

    realise(values["lighting"], scene, shadow_map_size=config.render.shadow_map_size)
    # a key light and ceiling point lights (randomisers/floorplan_scene.py)
    pad_lights(scene, light_slots(0, max(config.lighting.lights[1], 1) - 1))
    return NavScene(scene, cams, robots, things, instance_lut, class_lut)
