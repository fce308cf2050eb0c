"""Off-screen capture of one camera: colour, metric depth and per-entity ids, plus its calibration.

Conventions (also in docs/data-formats.md): intrinsics K is 3x3 in pixels with the origin at the top-left
pixel corner; extrinsics E is the 4x4 world-to-camera transform in the OpenCV camera frame
(x right, y down, z forward), so ``x_cam = E @ x_world`` and ``uv ~ K @ x_cam[:3]``.

Stage clock names (``benchmarks/stages.py``): ``render`` = ``take_picture`` and the first
``get_picture``, which waits for the frame (lavapipe renders asynchronously); ``read_back`` =
the other pictures; ``convert`` = float pictures -> stored integer images.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import sapien

from datagen.geometry import world_to_cv_camera
from datagen.sensing import picture_conversion as conversion
from datagen.sensing.cameras import add_camera
from datagen.sensing.path_tracing import PathTracing, raytraced_rgb
from datagen.sensing.picture_conversion import DEPTH_MAX_UNITS, DEPTH_SCALE
from datagen.sensing.stage_clock import timed

__all__ = ["DEPTH_MAX_UNITS", "DEPTH_SCALE", "Frame", "capture", "keep_renderer_alive"]

_keepalive: list = []


def keep_renderer_alive() -> None:
    """Holds one tiny scene for the life of the process.

    SAPIEN releases its shared render resources (pipelines, shader modules) when the last scene
    is destroyed; a fresh scene per sample then pays their setup again. With the machine's cached
    BRDF table (``brdf_lut.py``) the first frame takes ~0.2 s on lavapipe instead of ~3.6 s.
    """
    if not _keepalive:
        scene = sapien.Scene()
        camera = add_camera(scene, "keepalive", 8, 8, 1.0, 0.01, 1.0)
        scene.update_render()
        camera.take_picture()
        camera.get_picture("Color")  # waits for the frame: an exit while it renders crashes
        _keepalive.append((scene, camera))


@dataclass
class Frame:
    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray  # (H, W) uint16 millimetres along the optical axis; 0 = no surface
    entity_ids: np.ndarray  # (H, W) uint32 SAPIEN per-scene entity id; 0 = nothing
    intrinsics: np.ndarray  # (3, 3)
    extrinsics: np.ndarray  # (4, 4) world -> OpenCV camera


@functools.cache
def gpu_read_back(device_is_cuda: bool) -> bool:
    """Convert on the GPU when SAPIEN renders on a CUDA device and torch can use it."""
    if not device_is_cuda:
        return False
    try:
        import torch
    except ImportError:
        return False
    return bool(torch.cuda.is_available())


def _render_device_is_cuda(camera: sapien.render.RenderCameraComponent) -> bool:
    return bool(camera.entity.scene.render_system.device.is_cuda())


def _pictures_cpu(camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    with timed("render"):
        camera.take_picture()
        rgba = camera.get_picture("Color")  # (H, W, 4) float32 in [0, 1]
    with timed("read_back"):
        position = camera.get_picture("Position")  # (H, W, 4): OpenGL camera xyz, w < 1 on surfaces
        segmentation = camera.get_picture("Segmentation")  # (H, W, 4) uint32: [..., 1] = entity
    with timed("convert"):
        return (
            conversion.rgb_from_colour(rgba),
            conversion.depth_from_position(position),
            conversion.ids_from_segmentation(segmentation),
        )


def _pictures_gpu(camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The same bytes as :func:`_pictures_cpu`, converted on the GPU; only the stored integer
    images are copied back."""
    with timed("render"):
        camera.take_picture()
        rgba = camera.get_picture_cuda("Color").torch()
    with timed("read_back"):
        position = camera.get_picture_cuda("Position").torch()
        segmentation = camera.get_picture_cuda("Segmentation").torch()
    with timed("convert"):
        rgb = conversion.rgb_from_colour_torch(rgba).cpu().numpy()
        depth = conversion.depth_from_position_torch(position).cpu().numpy().astype(np.uint16)
        ids = conversion.ids_from_segmentation_torch(segmentation).cpu().numpy().view(np.uint32)
        return rgb, depth, ids


def capture(
    camera: sapien.render.RenderCameraComponent, path_tracing: PathTracing | None = None
) -> Frame:
    """Renders ``camera``; the caller has already called ``scene.update_render()``. With
    ``path_tracing`` the colour image is path-traced from the same scene state, after the
    rasterized pictures the depth and the ids come from (``path_tracing.py``)."""
    if gpu_read_back(_render_device_is_cuda(camera)):
        rgb, depth, entity_ids = _pictures_gpu(camera)
    else:
        rgb, depth, entity_ids = _pictures_cpu(camera)
    if path_tracing is not None:
        rgb = raytraced_rgb(camera, path_tracing)
    return Frame(
        rgb=rgb,
        depth=depth,
        entity_ids=entity_ids,
        intrinsics=np.asarray(camera.get_intrinsic_matrix(), float),
        extrinsics=world_to_cv_camera(
            np.asarray(camera.global_pose.to_transformation_matrix(), float)
        ),
    )
