"""SAPIEN's BRDF lookup table, computed once per machine instead of once per process.

SAPIEN's default shader reads a 512x512 ``rg16f`` table of the split-sum specular BRDF
(``samplerBRDFLUT``). When a camera is not given one, SAPIEN computes it with a compute shader
(1024 importance samples per texel) the first time a process renders: about 3.5 s of wall time
and 7 CPU-s on lavapipe, the largest part of a worker's start-up (docs/performance.md,
"Start-up"). The table depends only on SAPIEN and the Vulkan device, so it is read back once
with a probe shader that copies it texel by texel into a float32 picture, stored in the cache
(``datagen.user_cache``: ``~/.cache/datagen/render/``) under the SAPIEN version and the
device, and handed to every camera with ``set_texture("BRDFLUT", ...)``: the same half floats,
so every rendered byte is the one SAPIEN's own table gives (``tests/sensing/test_brdf_lut.py``
checks it under an environment map, the only light the table weighs; datagen's scenes have
none, so there it changes no pixel, and ``tests/test_golden.py`` keeps its bytes).
"""

from __future__ import annotations

import functools
import hashlib
import logging
import shutil
import tempfile
from pathlib import Path

import numpy as np
import sapien

from datagen.exports.files import replace_file
from datagen.user_cache import user_cache

LUT_SIZE = 512  # texels a side, as svulkan2's SVResourceManager::getDefaultBRDFLUT makes it
# copies the table into the colour target: pixel (row y, column x) = texel (x, y)
_PROBE_FRAGMENT = """#version 450
#extension GL_GOOGLE_include_directive : enable
#define SET_NUM 0
#include "./camera_set.glsl"
#undef SET_NUM
#define SET_NUM 1
#include "./object_set.glsl"
#undef SET_NUM
#define SET_NUM 2
#include "./material_set.glsl"
#undef SET_NUM
#define SET_NUM 3
#include "./scene_set.glsl"
#undef SET_NUM

layout(location = 0) in vec4 inPosition;
layout(location = 0) out vec4 outColor;
layout(location = 1) out vec4 outPosition;
layout(location = 2) out uvec4 outSegmentation;

void main() {
  outPosition = inPosition;
  outSegmentation = objectDataBuffer.segmentation;
  vec2 lut = texelFetch(samplerBRDFLUT, ivec2(gl_FragCoord.xy), 0).xy;
  outColor = vec4(lut, materialBuffer.baseColor.z * 0.0 + sceneBuffer.ambientLight.x * 0.0, 1.0);
}
"""
_PROBE_VERTEX = """#version 450
#extension GL_GOOGLE_include_directive : enable
#define SET_NUM 0
#include "./camera_set.glsl"
#undef SET_NUM
#define SET_NUM 1
#include "./object_set.glsl"
#undef SET_NUM

layout(location = 0) in vec3 position;  // the vertex layout of SAPIEN's shaders
layout(location = 1) in vec3 normal;
layout(location = 2) in vec2 uv;
layout(location = 3) in vec3 tangent;
layout(location = 4) in vec3 bitangent;
layout(location = 0) out vec4 outPosition;

void main() {
  outPosition = cameraBuffer.viewMatrix * (objectTransformBuffer.modelMatrix * vec4(position, 1));
  gl_Position = cameraBuffer.projectionMatrix * outPosition;
}
"""
log = logging.getLogger(__name__)


def cache_file() -> Path:
    device = sapien.render.get_device_summary().strip()
    key = hashlib.sha256(f"{sapien.__version__}\n{device}".encode()).hexdigest()[:16]
    return user_cache("render") / f"brdf_lut-{key}.npy"


def attach_brdf_lut(camera: sapien.render.RenderCameraComponent) -> None:
    """Gives ``camera`` the machine's cached table (read back first if there is none yet).
    Where the probe fails (a device whose shaders differ), SAPIEN computes its own as before."""
    if (texture := _texture()) is not None:
        camera.set_texture("BRDFLUT", texture)


@functools.cache  # one texture per process, alive as long as its cameras
def _texture() -> sapien.render.RenderTexture | None:
    try:
        table = _load_or_read_back()
    except RuntimeError as exc:
        log.warning("BRDF table not cached (%s): SAPIEN computes it in each process", exc)
        return None
    return sapien.render.RenderTexture(table, 2, "R16G16Sfloat", address_mode="edge")


def _load_or_read_back() -> np.ndarray:
    path = cache_file()
    try:
        table = np.load(path, allow_pickle=False)
        if table.shape == (LUT_SIZE, LUT_SIZE, 2) and table.dtype == np.float16:
            return table
    except (OSError, ValueError):
        pass  # absent or torn: read it back again
    table = read_back_default_lut()
    path.parent.mkdir(parents=True, exist_ok=True)
    # atomic: two workers reading it back at once both write whole files
    replace_file(path, lambda tmp: np.save(tmp, table, allow_pickle=False))
    return table


def read_back_default_lut() -> np.ndarray:
    """SAPIEN's own table on this device, (512, 512, 2) float16, through a probe shader."""
    default_dir = Path(sapien.__file__).parent / "vulkan_shader" / "default"
    previous = sapien.render.get_camera_shader_dir()
    with tempfile.TemporaryDirectory(prefix="datagen-brdf-probe-") as tmp:
        probe = Path(tmp) / "probe"
        probe.mkdir()
        for name in ("camera_set.glsl", "object_set.glsl", "material_set.glsl", "scene_set.glsl"):
            shutil.copy(default_dir / name, probe / name)
        shutil.copytree(default_dir.parent / "common", Path(tmp) / "common")
        shutil.copy(default_dir / "shadow.vert", probe / "shadow.vert")
        (probe / "gbuffer.vert").write_text(_PROBE_VERTEX)
        (probe / "gbuffer.frag").write_text(_PROBE_FRAGMENT)
        sapien.render.set_camera_shader_dir(str(probe))
        try:
            scene = sapien.Scene()
            builder = scene.create_actor_builder()
            builder.add_box_visual(half_size=[0.01, 10.0, 10.0])  # fills the whole view
            builder.build_kinematic().set_pose(sapien.Pose([1.0, 0.0, 0.0]))
            camera = scene.add_camera("brdf-lut", LUT_SIZE, LUT_SIZE, 1.0, 0.01, 10.0)
            scene.update_render()
            camera.take_picture()
            picture = camera.get_picture("Color")  # (512, 512, 4) float32
        finally:
            sapien.render.set_camera_shader_dir(previous)
    if not np.all(picture[..., 3] == 1.0):
        raise RuntimeError("the BRDF table probe did not cover every texel")
    table = picture[..., :2].astype(np.float16)
    if not np.array_equal(table.astype(np.float32), picture[..., :2]):
        raise RuntimeError("the BRDF table probe read values that are not half floats")
    return table
