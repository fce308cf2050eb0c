"""Every camera datagen renders with, made in one place: datagen's shader pack
(:mod:`datagen.sensing.shader_pack`) and the machine's BRDF table
(:mod:`datagen.sensing.brdf_lut`). What ``scene.add_camera`` and
``scene.add_mounted_camera`` make otherwise."""

from __future__ import annotations

import sapien

from datagen.sensing.brdf_lut import attach_brdf_lut
from datagen.sensing.shader_pack import shader_dir


def add_camera(
    scene: sapien.Scene,
    name: str,
    width: int,
    height: int,
    fovy: float,
    near: float,
    far: float,
    mount: sapien.Entity | None = None,
    pose: sapien.Pose | None = None,
) -> sapien.render.RenderCameraComponent:
    """A ``width`` x ``height`` camera (``fovy`` radians; ``near``, ``far`` metres) on an entity
    of its own named ``name``, or on ``mount`` at ``pose`` in its frame."""
    camera = sapien.render.RenderCameraComponent(width, height, shader_dir())
    camera.set_fovy(fovy, compute_x=True)
    camera.near, camera.far = near, far
    camera.name = name
    if mount is None:
        mount = sapien.Entity()
        mount.name = name
        mount.add_component(camera)
        scene.add_entity(mount)
    else:
        mount.add_component(camera)
        camera.local_pose = pose if pose is not None else sapien.Pose()
    attach_brdf_lut(camera)
    return camera


def twin_camera(
    scene: sapien.Scene, camera: sapien.render.RenderCameraComponent, shader_dir: str
) -> sapien.render.RenderCameraComponent:
    """A camera of ``camera``'s size, field of view, clip planes and pose, with the shaders of
    ``shader_dir`` and SAPIEN's own BRDF table: the other side of a comparison of the two."""
    twin = sapien.render.RenderCameraComponent(camera.width, camera.height, shader_dir)
    twin.set_fovy(camera.fovy, compute_x=True)
    twin.near, twin.far = camera.near, camera.far
    mount = sapien.Entity()
    mount.add_component(twin)
    scene.add_entity(mount)
    mount.set_pose(camera.entity.pose)
    return twin
