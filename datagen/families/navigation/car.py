"""A car-like robot with Ackermann steering for navigation scenes: a procedural body, four wheels
(the front two turn with the steering angle, each by its own Ackermann angle) and a camera on a
mast at the front of the body. Drawn only: each frame puts it at its pose on the expert trajectory.

Car frame: origin on the floor under the body's centre (the centre of its footprint disk and the
pose of ``datagen.families.navigation.ackermann``), x forward, y left, z up. Sizes in footprint radii r
(``navigation.robot_radius``): the body is 1.6 r long and 1.0 r wide (its half diagonal, 0.94 r,
fits the footprint disk), the rear axle ``CAR_REAR`` r behind the centre, the wheelbase
``CAR_WHEELBASE`` r. The camera looks out from the front of the mast's pod, ahead of every part
of the car: a view that stays within 90 degrees of straight ahead (``|pitch| + fovy / 2 <= 90``,
which the config checks) never sees the car itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np
import sapien
import trimesh

from datagen.families.navigation.episode import CAR_REAR, CAR_WHEELBASE
from datagen.scene_values.material import Material
from datagen.sensing.cameras import add_camera
from datagen.worlds.surfaces import render_material, render_shape

WHEEL_RADIUS, WHEEL_WIDTH = 0.18, 0.12  # footprint radii
BODY_LENGTH, BODY_WIDTH = 1.6, 1.0  # footprint radii
POD = (0.12, 0.16, 0.1)  # the camera's pod: length, width, height (footprint radii)
POD_AHEAD = BODY_LENGTH / 2 - POD[0] / 2  # its centre: its front flush with the body's front
CAMERA_AHEAD, CAMERA_HEIGHT = BODY_LENGTH / 2 + 0.005, 0.9  # footprint radii from the centre


@dataclass
class CarBody:
    chassis: sapien.Entity
    wheels: list[sapien.Entity]  # rear left, rear right, front left, front right
    radius: float  # metres (the footprint radius)

    @property
    def wheelbase(self) -> float:
        return CAR_WHEELBASE * self.radius

    @property
    def rear(self) -> float:
        """Metres from the rear axle forward to the body's centre."""
        return CAR_REAR * self.radius

    @property
    def entities(self) -> list[sapien.Entity]:
        return [self.chassis, *self.wheels]

    def set_base(self, x: float, y: float, yaw: float, steer: float = 0.0) -> None:
        """The car at (x, y, yaw), its front wheels turned for the steering angle ``steer``
        (radians, the bicycle model's middle wheel: each wheel turns about its own centre of the
        turn, the inner one more)."""
        base = sapien.Pose([x, y, 0.0], _yaw_quat(yaw))
        self.chassis.set_pose(base)
        r, half_track = self.radius, 0.5 * self.radius - WHEEL_WIDTH * self.radius / 2
        for k, wheel in enumerate(self.wheels):
            front, side = k >= 2, 1.0 if k % 2 == 0 else -1.0
            angle = _ackermann(steer, self.wheelbase, side * half_track) if front else 0.0
            ahead = (self.wheelbase if front else 0.0) - self.rear  # metres from the centre
            local = sapien.Pose([ahead, side * half_track, WHEEL_RADIUS * r], _yaw_quat(angle))
            wheel.set_pose(base * local)


def _yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def _ackermann(steer: float, wheelbase: float, offset: float) -> float:
    """The angle of a front wheel ``offset`` metres left of the middle for the middle's angle."""
    if abs(steer) < 1e-9:
        return 0.0
    radius = wheelbase / math.tan(steer)  # signed: positive turns left
    return math.atan(wheelbase / (radius - offset))


def build_car(scene: sapien.Scene, radius: float, materials: dict[str, Material]) -> CarBody:
    """The car in ``scene`` (its parts coloured by ``materials``: ``body``, ``wheels``, ``mast``)."""
    r = radius
    body = sapien.render.RenderBodyComponent()
    clearance, height = 0.12 * r, 0.35 * r
    hull = trimesh.creation.box(extents=[BODY_LENGTH * r, BODY_WIDTH * r, height])
    hull.apply_translation([0.0, 0.0, clearance + height / 2])
    body.attach(render_shape(hull, materials["body"]))
    mast = trimesh.creation.box(
        extents=[0.08 * r, 0.08 * r, CAMERA_HEIGHT * r - clearance - height]
    )
    mast.apply_translation([POD_AHEAD * r, 0.0, (CAMERA_HEIGHT * r + clearance + height) / 2])
    pod = trimesh.creation.box(extents=[v * r for v in POD])
    pod.apply_translation([POD_AHEAD * r, 0.0, CAMERA_HEIGHT * r])
    mast_and_pod = cast(trimesh.Trimesh, trimesh.util.concatenate([mast, pod]))
    body.attach(render_shape(mast_and_pod, materials["mast"]))
    chassis = sapien.Entity()
    chassis.name = "car"
    chassis.add_component(body)
    scene.add_entity(chassis)
    wheels = []
    for k in range(4):
        tyre = sapien.render.RenderBodyComponent()
        shape = sapien.render.RenderShapeCylinder(
            WHEEL_RADIUS * r, WHEEL_WIDTH * r / 2, render_material(materials["wheels"])
        )
        shape.local_pose = sapien.Pose(q=[math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)])  # axis along y
        tyre.attach(shape)
        wheel = sapien.Entity()
        wheel.name = f"car_wheel_{k}"
        wheel.add_component(tyre)
        scene.add_entity(wheel)
        wheels.append(wheel)
    car = CarBody(chassis, wheels, radius)
    car.set_base(0.0, 0.0, 0.0)
    return car


def car_body(config, scene: sapien.Scene, cam: dict, values: dict):
    """The car (painted as ``values["materials"]["car"]``), its entities and its camera on the
    mast's pod."""
    r, radius = config.render, config.navigation.robot_radius
    car = build_car(scene, radius, values["materials"]["car"])
    pose = camera_pose(radius, cam["pitch_deg"])
    fovy = math.radians(cam["fovy_deg"])
    camera = add_camera(scene, "head", r.width, r.height, fovy, r.near, r.far, car.chassis, pose)
    return car, car.entities, camera


def camera_pose(radius: float, pitch_down_deg: float) -> sapien.Pose:
    """SAPIEN camera frame (x forward, y left, z up) on the chassis: the pod's front, tilted down."""
    angle = math.radians(pitch_down_deg)  # a positive turn about y points x down
    position = np.array([CAMERA_AHEAD, 0.0, CAMERA_HEIGHT]) * radius
    return sapien.Pose(position.tolist(), [math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])
