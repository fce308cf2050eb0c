"""An example ground robot, ``rover``: a low box on the floor with a camera at its front, driven
by datagen's own differential-drive expert. It is what docs/extending.md ("A ground robot")
walks: one record (``ROVER``), registered by one entry point (``datagen.ground_robots``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sapien

from datagen.plugin_records import GroundRobot
from datagen.sensing.cameras import add_camera

LENGTH, WIDTH, HEIGHT = 1.4, 1.0, 0.5  # footprint radii
COLOUR = [0.85, 0.45, 0.1, 1.0]


@dataclass
class RoverBody:
    entity: sapien.Entity

    def set_base(self, x: float, y: float, yaw: float, steer: float = 0.0) -> None:
        self.entity.set_pose(sapien.Pose([x, y, 0.0], [math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)]))


def rover_body(config, scene: sapien.Scene, cam: dict, values: dict):
    """The box, its one entity, and its camera at its front face looking ahead and down."""
    r, radius = config.render, config.navigation.robot_radius
    body = sapien.render.RenderBodyComponent()
    half = np.array([LENGTH, WIDTH, HEIGHT]) * radius / 2
    shape = sapien.render.RenderShapeBox(half, sapien.render.RenderMaterial(base_color=COLOUR))
    shape.local_pose = sapien.Pose([0.0, 0.0, half[2]])
    body.attach(shape)
    entity = sapien.Entity()
    entity.name = "rover"
    entity.add_component(body)
    scene.add_entity(entity)
    pitch = math.radians(cam["pitch_deg"])  # a positive turn about y points x down
    mount = sapien.Pose(
        [half[0] + 0.01, 0.0, 2 * half[2]], [math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0]
    )
    fovy = math.radians(cam["fovy_deg"])
    camera = add_camera(scene, "head", r.width, r.height, fovy, r.near, r.far, entity, mount)
    rover = RoverBody(entity)
    rover.set_base(0.0, 0.0, 0.0)
    return rover, [entity], camera


def describe(config, scene) -> dict:
    return {
        "name": "rover",
        "radius": config.navigation.robot_radius,
        "size_m": [round(v * config.navigation.robot_radius, 6) for v in (LENGTH, WIDTH, HEIGHT)],
        "commands": ["linear_m_s", "angular_rad_s"],
    }


ROVER = GroundRobot(
    "rover",
    "a box on the floor with a camera at its front (the docs/extending.md example)",
    drive="datagen.families.navigation.episode:differential_drive",
    body="example_rover:rover_body",
    describe="example_rover:describe",
    view_limit_deg=80.0,
)
