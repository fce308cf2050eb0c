"""A worker's warm-up, before it reports ``ready``: what its first sample would otherwise pay
once is paid at start-up (under the start-up grace, docs/liveness.md), so that
``build.sample_timeout_s`` measures one sample alone. Measured on lavapipe, at rest:

- the renderer: one tiny scene held for the life of the process (``keep_renderer_alive``):
  datagen's cameras, their pipelines and the machine's cached BRDF table; with
  ``render.shader: raytraced``, one tiny path-traced picture (SAPIEN compiles its ``rt``
  shaders) and the check that ``render.denoiser`` runs on this machine;
- the family's modules: its ``produce`` imported, with everything it imports (a grasp
  tabletop's first sample: 0.4 s of imports);
- a user's meshes (``objects.source: folder``): their convex parts, read from the machine's
  cache, or decomposed once for the machine by the workers starting together, each taking the
  meshes no other is decomposing (:mod:`datagen.assets.mesh_decomposition`);
- a family from a plug-in: one frame of SAPIEN's own camera (``scene.add_camera``, as the
  docs/extending.md example renders), since SAPIEN computes its BRDF table on the first such
  frame of a process: 3-4 s at rest and 9 s on a loaded 2-core machine, once the first sample
  of ``example_blocks``. datagen's own families render only through
  ``datagen.sensing.cameras``, which hands every camera the cached table.

Nothing drawn here reaches a sample: a sample's bytes are a function of (seed, index) alone.
"""

from __future__ import annotations

import logging

import sapien

from datagen.config import BuildConfig
from datagen.registries import FAMILIES
from datagen.registry import resolve
from datagen.sensing import path_tracing
from datagen.sensing.render import keep_renderer_alive

log = logging.getLogger(__name__)
BUILT_IN = "datagen."  # the module prefix of datagen's own families


def warm_up(config: BuildConfig) -> None:
    """Readies this process to make samples of ``config``'s family."""
    keep_renderer_alive()
    if config.render.shader == "raytraced":
        path_tracing.warm_up(config.render.denoiser)  # a denoiser that cannot run: refused here
    if config.objects.source == "folder":
        _user_meshes(config.objects.assets_dir)
    family = FAMILIES[config.scene]
    try:
        resolve(family.produce)
    except Exception as exc:  # the first sample raises it again, under build.on_sample_error
        log.debug("warm-up: %s cannot be imported: %r", family.produce, exc)
        return
    if not family.produce.startswith(BUILT_IN):
        _first_frame_of_a_sapien_camera()


def _user_meshes(assets_dir: str) -> None:
    from datagen.assets.mesh_library import AssetError, load_library

    try:
        load_library(assets_dir)
    except AssetError as exc:  # the first sample raises it again, under build.on_sample_error
        log.debug("warm-up: %s", exc)


def _first_frame_of_a_sapien_camera() -> None:
    scene = sapien.Scene()
    camera = scene.add_camera("warm-up", 8, 8, 1.0, 0.01, 10.0)
    scene.update_render()
    camera.take_picture()
    camera.get_picture("Color")  # waits for the frame: an exit while it renders crashes
