"""Path-traced colour images (``render.shader: raytraced``): a view's colour image drawn by
SAPIEN's ray-tracing shader pack, while every label is still drawn by the rasterizer.

A path-traced view is rendered twice from one scene state. The view's own (rasterized) camera
gives depth, segmentation and all that is annotated from them, the same bytes as a rasterized
build of the seed; a twin camera on the same mount, with the same local pose, size and
intrinsics and SAPIEN's ``rt`` shaders, gives the colour image. The twin lives for one picture:
SAPIEN's path tracer seeds its paths from a fixed number and a camera's picture count, and
blends a camera's later pictures into its earlier ones until the scene's render state changes,
so a fresh camera's first picture is a function of the scene alone. The samples per pixel and the path
depth are the twin's own properties; the denoiser is a process-wide setting SAPIEN reads when a
camera joins a scene, so it is set for the twin and put back.

SAPIEN's denoisers (``oidn`` as its wheel ships it, ``optix``) run on CUDA. Without CUDA SAPIEN
logs an error and renders without denoising; :func:`check_denoiser` tells the two apart by two
pictures of a small scene, with and without the denoiser, and refuses a denoiser that changes
nothing.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sapien

from datagen.errors import ConfigError
from datagen.seeding import sample_rng
from datagen.sensing import picture_conversion as conversion
from datagen.sensing.cameras import add_camera
from datagen.sensing.stage_clock import timed

RT_SHADERS = str(Path(sapien.__file__).parent / "vulkan_shader" / "rt")


@dataclass(frozen=True)
class PathTracing:
    """How a path-traced colour image is drawn (``render.samples_per_pixel``, ...)."""

    samples_per_pixel: int = 16
    path_depth: int = 8  # bounces after the first hit; 0: direct light only
    denoiser: str = "none"  # "none", "oidn" or "optix"


def path_tracing_of(render) -> PathTracing:
    """The path tracing a ``RenderConfig`` asks for."""
    return PathTracing(render.samples_per_pixel, render.path_depth, render.denoiser)


def view_is_path_traced(render, seed: int, index: int, camera: str, attempt: int = 0) -> bool:
    """Whether view ``camera`` of sample ``index`` is path-traced: never with ``render.shader:
    rasterized``; else with probability ``render.raytraced_share``, drawn from the stream
    ``raytraced.<camera>``."""
    if render.shader != "raytraced":
        return False
    rng = sample_rng(seed, index, f"raytraced.{camera}", attempt)
    return bool(rng.random() < render.raytraced_share)


def raytraced_rgb(camera: sapien.render.RenderCameraComponent, tracing: PathTracing) -> np.ndarray:
    """(H, W, 3) uint8: ``camera``'s view path-traced, converted as a rasterized colour image
    is. The caller has called ``scene.update_render()``; this calls it again for the twin."""
    check_denoiser(tracing.denoiser)
    return _picture(camera, tracing)


def check_denoiser(denoiser: str) -> None:
    """Raises ConfigError naming ``render.denoiser`` when ``denoiser`` does not run here."""
    if denoiser != "none" and not _denoiser_runs(denoiser):
        device = sapien.render.get_device_summary().strip().splitlines()
        raise ConfigError(
            f"render.denoiser: {denoiser!r} does not run on this machine's renderer "
            f"({device[0].strip() if device else 'no device'}): SAPIEN's denoisers need an "
            f"NVIDIA GPU with CUDA; use 'none'"
        )


def _picture(camera: sapien.render.RenderCameraComponent, tracing: PathTracing) -> np.ndarray:
    with traced_twin(camera, tracing) as twin:
        with timed("render"):
            camera.entity.scene.update_render()
            twin.take_picture()
            rgba = twin.get_picture("Color")  # (H, W, 4) float32 in [0, 1]
        with timed("convert"):
            return conversion.rgb_from_colour(rgba)


@contextmanager
def traced_twin(
    camera: sapien.render.RenderCameraComponent, tracing: PathTracing
) -> Iterator[sapien.render.RenderCameraComponent]:
    """``camera``'s path-tracing twin, on its mount while the block runs. Its first picture
    (after ``scene.update_render()``) is the path-traced view; later ones blend into it."""
    twin = sapien.render.RenderCameraComponent(camera.width, camera.height, RT_SHADERS)
    k = camera.get_intrinsic_matrix()  # float32, as SAPIEN keeps them: copied exactly
    twin.set_perspective_parameters(
        camera.near, camera.far, k[0, 0], k[1, 1], k[0, 2], k[1, 2], k[0, 1]
    )
    twin.local_pose = camera.local_pose
    twin.set_property("spp", tracing.samples_per_pixel)
    twin.set_property("maxDepth", tracing.path_depth)
    previous = sapien.render.get_ray_tracing_denoiser()
    sapien.render.set_ray_tracing_denoiser(tracing.denoiser)
    try:
        camera.entity.add_component(twin)  # SAPIEN reads the denoiser here
    finally:
        sapien.render.set_ray_tracing_denoiser(previous)
    try:
        yield twin
    finally:
        camera.entity.remove_component(twin)


def warm_up(denoiser: str) -> None:
    """Pays a process's first path-traced picture (SAPIEN compiles the ``rt`` shaders) and
    checks ``denoiser``, so that a worker refuses it at start-up rather than at every sample."""
    scene, camera = probe_scene()
    _picture(camera, PathTracing(samples_per_pixel=1, path_depth=0))
    check_denoiser(denoiser)
    del scene  # held until its camera has rendered


@functools.cache
def _denoiser_runs(denoiser: str) -> bool:
    """Whether pictures of a small scene at one path a pixel, with ``denoiser`` and without,
    differ (once per process and denoiser)."""
    scene, camera = probe_scene()
    noisy, denoised = (
        _picture(camera, PathTracing(samples_per_pixel=1, path_depth=2, denoiser=name))
        for name in ("none", denoiser)
    )
    del scene  # held until its camera has rendered
    return not np.array_equal(noisy, denoised)


def probe_scene() -> tuple[sapien.Scene, sapien.render.RenderCameraComponent]:
    """A scene of a box on a floor under a point light, and a 32 x 32 camera looking at it."""
    scene = sapien.Scene()
    scene.add_point_light([0.4, 0.0, 0.5], [0.6, 0.6, 0.6])
    builder = scene.create_actor_builder()
    builder.add_box_visual(half_size=[0.1, 0.1, 0.1], material=[0.8, 0.3, 0.2])
    builder.add_box_visual(sapien.Pose([0, 0, -0.11]), [1.0, 1.0, 0.01], [0.8, 0.8, 0.8])
    builder.build_static(name="box on a floor")
    camera = add_camera(scene, "path-tracing-probe", 32, 32, 1.0, 0.01, 10.0)
    camera.entity.set_pose(sapien.Pose([-0.8, 0.0, 0.4], [0.9659258, 0.0, 0.258819, 0.0]))
    scene.update_render()
    return scene, camera
