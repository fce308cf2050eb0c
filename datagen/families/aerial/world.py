"""Aerial scene: a volume of :mod:`datagen.families.aerial.volumes` built in SAPIEN, with a procedural
quadrotor per drone carrying a forward camera (and optionally one looking down).

World frame as the volume's: z up, metres, the floor plan's origin; the floor top is z = 0.
Drones are drawn only (no physics): each frame puts every drone at its pose on its trajectory.
Camera mounts in the body frame (x forward, y left, z up): the forward camera at the pod's front,
tilted up by its sampled pitch; with ``aerial.stereo_baseline``, a right camera that far to its
right (along the body's -y), tilted and zoomed alike (a rectified pair); the downward camera under
the body, turned 90 degrees nose-down, so its image's up points along the body's x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import sapien

from datagen.config import BuildConfig
from datagen.families.aerial.airframe import camera_mounts, drone_parts, right_camera
from datagen.families.aerial.episode import AerialEpisode
from datagen.plugin_records import Airframe
from datagen.registries import AIRFRAMES
from datagen.sensing.cameras import add_camera
from datagen.worlds.class_names import AERIAL_CLASSES
from datagen.worlds.realise import light_slots, pad_lights, realise
from datagen.worlds.surfaces import box_entity, render_material, render_shape
from datagen.worlds.things import Thing, rect_box

AERIAL_CLASS_ID = {name: i for i, name in enumerate(AERIAL_CLASSES)}
FLOOR_MARGIN = 1.0  # metres of floor beyond the plan
FLOOR_THICKNESS = 0.05  # metres
GOAL_RADIUS = 0.08  # metres: the goal marker's sphere


@dataclass
class AerialScene:
    scene: sapien.Scene
    drones: list[sapien.Entity]
    cameras: dict[str, sapien.render.RenderCameraComponent]  # "d0", "d0_right", "d0_down", ...
    camera_in_body: dict[str, np.ndarray]  # name -> 4x4 camera (OpenCV axes) in its drone's frame
    things: list[Thing]
    instance_lut: np.ndarray  # per_scene_id -> instance id
    class_lut: np.ndarray  # per_scene_id -> class id

    def pose_drones(self, positions: np.ndarray, rotations: np.ndarray) -> None:
        """Every drone at its position (n, 3) and body-to-world rotation (n, 3, 3)."""
        for entity, p, r in zip(self.drones, positions, rotations, strict=True):
            matrix = np.eye(4)
            matrix[:3, :3], matrix[:3, 3] = r, p
            entity.set_pose(sapien.Pose(matrix))

    def label_maps(self, entity_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ids = np.minimum(entity_ids, len(self.class_lut) - 1)
        return self.instance_lut[ids], self.class_lut[ids]


def _box(box) -> tuple[list[float], list[float]]:
    x0, y0, z0, x1, y1, z1 = box
    return rect_box((x0, y0, x1, y1), z0, z1)


def _drone(
    scene: sapien.Scene, name: str, airframe: Airframe, shape: Any, materials: dict[str, Any]
) -> sapien.Entity:
    body = sapien.render.RenderBodyComponent()
    for part, mesh in drone_parts(airframe, shape).items():
        body.attach(render_shape(mesh, materials[part]))
    entity = sapien.Entity()
    entity.name = name
    entity.add_component(body)
    scene.add_entity(entity)
    return entity


# OpenCV camera axes (x right, y down, z forward) in SAPIEN's camera frame (x forward, y left, z up)
_CV_IN_SAPIEN = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 0, 1]], float)


def _mount(position: np.ndarray, pitch_up_deg: float) -> np.ndarray:
    """4x4 SAPIEN camera frame in the body frame: at ``position``, turned nose-up by the pitch."""
    angle = -math.radians(pitch_up_deg)  # a positive turn about y points x down
    c, s = math.cos(angle), math.sin(angle)
    matrix = np.eye(4)
    matrix[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    matrix[:3, 3] = position
    return matrix


def build_aerial_scene(
    config: BuildConfig, episode: AerialEpisode, values: dict[str, Any]
) -> AerialScene:
    scene = sapien.Scene()
    volume, materials = episode.volume, values["materials"]
    width, depth = volume.layout.size_m
    floor_box = (
        -FLOOR_MARGIN,
        -FLOOR_MARGIN,
        -FLOOR_THICKNESS,
        width + FLOOR_MARGIN,
        depth + FLOOR_MARGIN,
        0.0,
    )
    floor = box_entity(scene, "floor", [_box(floor_box)], materials["floor"], collide=False)
    stuff = {floor.per_scene_id: "floor"}
    things: list[Thing] = []
    for i, solid in enumerate(volume.solids):
        material = (
            materials["walls"]
            if solid.kind == "wall"
            else materials.get(solid.kind, materials["obstacle"])
        )
        entity = box_entity(scene, f"{solid.kind}_{i}", [_box(solid.box)], material, collide=False)
        if solid.kind in ("wall", "ceiling"):
            stuff[entity.per_scene_id] = solid.kind
        else:
            things.append(Thing(0, "obstacle", f"{solid.kind}_{i}", [entity]))
    drones, cameras, camera_in_body = [], {}, {}
    r, airframe = config.render, AIRFRAMES[config.aerial.airframe]
    for k, (agent, shape) in enumerate(zip(episode.agents, episode.shapes, strict=True)):
        drone = _drone(scene, f"drone_{k}", airframe, shape, values["drones"][k])
        drones.append(drone)
        things.append(Thing(0, "drone", f"drone_{k}", [drone]))
        goal = sapien.render.RenderBodyComponent()
        goal.attach(
            sapien.render.RenderShapeSphere(GOAL_RADIUS, render_material(materials["goal_marker"]))
        )
        marker = sapien.Entity()
        marker.name = f"goal_{k}"
        marker.add_component(goal)
        scene.add_entity(marker)
        marker.set_pose(sapien.Pose(agent.goal.tolist()))
        things.append(Thing(0, "goal_marker", f"goal_{k}", [marker]))
        cam = values["cameras"][k]
        mounts = camera_mounts(airframe, shape, tuple(cam["forward"]["shift"]))
        forward = cam["forward"]
        rigs = {f"d{k}": (_mount(mounts["forward"], forward["pitch_deg"]), forward["fovy_deg"])}
        if config.aerial.stereo_baseline > 0:  # rectified: the same intrinsics, parallel axes
            right = right_camera(mounts["forward"], config.aerial.stereo_baseline)
            rigs[f"d{k}_right"] = (_mount(right, forward["pitch_deg"]), forward["fovy_deg"])
        if config.aerial.down_camera:
            rigs[f"d{k}_down"] = (_mount(mounts["down"], -90.0), cam["down"]["fovy_deg"])
        for name, (mount, fovy) in rigs.items():
            cameras[name] = add_camera(
                scene,
                name,
                r.width,
                r.height,
                math.radians(fovy),
                r.near,
                r.far,
                drone,
                sapien.Pose(mount),
            )
            camera_in_body[name] = mount @ _CV_IN_SAPIEN
    for i, thing in enumerate(things):
        thing.instance_id = i + 1
    size = 1 + max(e.per_scene_id for e in scene.entities)
    instance_lut, class_lut = np.zeros(size, np.uint16), np.zeros(size, np.uint8)
    for entity_id, name in stuff.items():
        class_lut[entity_id] = AERIAL_CLASS_ID[name]
    for thing in things:
        for entity in thing.entities:
            instance_lut[entity.per_scene_id] = thing.instance_id
            class_lut[entity.per_scene_id] = AERIAL_CLASS_ID[thing.class_name]
    realise(values["lighting"], scene, shadow_map_size=r.shadow_map_size)
    pad_lights(scene, light_slots(0, max(config.lighting.lights[1], 1) - 1))
    return AerialScene(scene, drones, cameras, camera_in_body, things, instance_lut, class_lut)
