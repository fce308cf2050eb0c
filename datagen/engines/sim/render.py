"""Off-screen capture of one camera: colour, metric depth and per-entity ids, plus its calibration.

Conventions (also in README): intrinsics K is 3x3 in pixels with the origin at the top-left
pixel corner; extrinsics E is the 4x4 world-to-camera transform in the OpenCV camera frame
(x right, y down, z forward), so ``x_cam = E @ x_world`` and ``uv ~ K @ x_cam[:3]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien

from datagen.geometry import world_to_cv_camera

DEPTH_SCALE = 0.001  # metres per depth unit: depth PNGs hold uint16 millimetres
DEPTH_MAX_UNITS = np.iinfo(np.uint16).max


_keepalive: list = []


def keep_renderer_alive() -> None:
    """Holds one tiny scene for the life of the process.

    SAPIEN releases its shared render resources (pipelines, shader modules) when the last scene
    is destroyed; a fresh scene per sample then pays ~3 s of setup on lavapipe instead of ~0.1 s.
    """
    if not _keepalive:
        scene = sapien.Scene()
        camera = scene.add_camera("keepalive", 8, 8, 1.0, 0.01, 1.0)
        scene.update_render()
        camera.take_picture()
        _keepalive.append((scene, camera))


@dataclass
class Frame:
    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray  # (H, W) uint16 millimetres along the optical axis; 0 = no surface
    entity_ids: np.ndarray  # (H, W) uint32 SAPIEN per-scene entity id; 0 = nothing
    intrinsics: np.ndarray  # (3, 3)
    extrinsics: np.ndarray  # (4, 4) world -> OpenCV camera


def capture(camera: sapien.render.RenderCameraComponent) -> Frame:
    """Renders ``camera``; the caller has already called ``scene.update_render()``."""
    camera.take_picture()
    rgba = camera.get_picture("Color")  # (H, W, 4) float in [0, 1]
    position = camera.get_picture("Position")  # (H, W, 4): OpenGL camera xyz, w < 1 on surfaces
    segmentation = camera.get_picture("Segmentation")  # (H, W, 4) uint32: [..., 1] = entity id

    rgb = np.clip(rgba[..., :3] * 255.0 + 0.5, 0, 255).astype(np.uint8)
    on_surface = position[..., 3] < 1.0
    depth_m = np.where(on_surface, -position[..., 2], 0.0)
    depth = np.clip(np.rint(depth_m / DEPTH_SCALE), 0, DEPTH_MAX_UNITS).astype(np.uint16)
    entity_ids = np.ascontiguousarray(segmentation[..., 1])
    return Frame(
        rgb=rgb,
        depth=depth,
        entity_ids=entity_ids,
        intrinsics=np.asarray(camera.get_intrinsic_matrix(), float),
        extrinsics=world_to_cv_camera(
            np.asarray(camera.global_pose.to_transformation_matrix(), float)
        ),
    )
