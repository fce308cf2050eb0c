"""A car-like robot with Ackermann steering for navigation scenes: a procedural body, four wheels
(the front two turn with the steering angle, each by its own Ackermann angle) and a camera on a
mast. Drawn only: each frame puts it at its pose on the expert trajectory.

Car frame: origin on the floor under the rear axle's centre (the bicycle model's reference
point), x forward, y left, z up. Sizes in footprint radii r (``navigation.robot_radius``): the
body is 1.6 r long and 1.0 r wide (its half diagonal, 0.94 r, fits the footprint disk about its
centre, 0.5 r ahead of the rear axle), the wheelbase ``CAR_WHEELBASE`` r.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sapien
import trimesh

from datagen.navigation.episode import CAR_WHEELBASE
from datagen.worlds.surfaces import render_material, render_shape

WHEEL_RADIUS, WHEEL_WIDTH = 0.18, 0.12  # footprint radii
CAMERA_AHEAD, CAMERA_HEIGHT = 0.75, 0.9  # the mast's camera, footprint radii from the rear axle


@dataclass
class CarBody:
    chassis: sapien.Entity
    wheels: list[sapien.Entity]  # rear left, rear right, front left, front right
    radius: float  # metres (the footprint radius)

    @property
    def wheelbase(self) -> float:
        return CAR_WHEELBASE * self.radius

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
            local = sapien.Pose(
                [self.wheelbase if front else 0.0, side * half_track, WHEEL_RADIUS * r],
                _yaw_quat(angle),
            )
            wheel.set_pose(base * local)


def _yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def _ackermann(steer: float, wheelbase: float, offset: float) -> float:
    """The angle of a front wheel ``offset`` metres left of the middle for the middle's angle."""
    if abs(steer) < 1e-9:
        return 0.0
    radius = wheelbase / math.tan(steer)  # signed: positive turns left
    return math.atan(wheelbase / (radius - offset))


def _shape(mesh: trimesh.Trimesh, material: dict) -> sapien.render.RenderShape:
    return render_shape(mesh, material)


def build_car(scene: sapien.Scene, radius: float, materials: dict) -> CarBody:
    """The car in ``scene`` (its parts coloured by ``materials``: ``body``, ``wheels``, ``mast``)."""
    r = radius
    body = sapien.render.RenderBodyComponent()
    clearance, height = 0.12 * r, 0.35 * r
    hull = trimesh.creation.box(extents=[1.6 * r, 1.0 * r, height])
    hull.apply_translation([0.5 * r, 0.0, clearance + height / 2])
    body.attach(_shape(hull, materials["body"]))
    mast = trimesh.creation.box(
        extents=[0.08 * r, 0.08 * r, CAMERA_HEIGHT * r - clearance - height]
    )
    mast.apply_translation([CAMERA_AHEAD * r, 0.0, (CAMERA_HEIGHT * r + clearance + height) / 2])
    pod = trimesh.creation.box(extents=[0.12 * r, 0.16 * r, 0.1 * r])
    pod.apply_translation([CAMERA_AHEAD * r, 0.0, CAMERA_HEIGHT * r])
    body.attach(_shape(trimesh.util.concatenate([mast, pod]), materials["mast"]))
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


def camera_pose(radius: float, pitch_down_deg: float) -> sapien.Pose:
    """SAPIEN camera frame (x forward, y left, z up) on the chassis: the pod's front, tilted down."""
    angle = math.radians(pitch_down_deg)  # a positive turn about y points x down
    position = np.array([CAMERA_AHEAD + 0.065, 0.0, CAMERA_HEIGHT]) * radius
    return sapien.Pose(position.tolist(), [math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])
