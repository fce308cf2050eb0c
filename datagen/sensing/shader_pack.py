"""datagen's camera shaders: SAPIEN's default shader pack with a 3x3 shadow filter instead of 5x5.

SAPIEN's default lighting pass filters each shadowed light with 25 ``textureGather`` taps per
pixel (``ShadowMapPCF`` in ``vulkan_shader/common/shadow.glsl``, offsets -2..2 texels). On a CPU
renderer that is a fifth of a default frame: the default scene has up to 6 shadowed lights (a
soft key light is 3 shadowed spots). Here the taps are 9, two texels apart (offsets -2, 0, 2):
each gather already blends a 2x2 texel footprint bilinearly, so the filter still covers the same
6x6 texels, with the same penumbra width; 2.5 % of a default frame's pixels change, by a few
levels, at shadow edges (docs/performance.md).

The pack is SAPIEN's own files (Apache-2.0, shipped in the sapien wheel) copied once per machine
into ``$XDG_CACHE_HOME/datagen/render/`` (else ``~/.cache/...``) under the SAPIEN version and
this recipe, with the one table replaced; every camera datagen makes uses it
(:mod:`datagen.sensing.cameras`). Should a SAPIEN release change the table, the pack is
SAPIEN's unchanged and a warning says so.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
import shutil
import tempfile
from pathlib import Path

import sapien

from datagen.user_cache import user_cache

log = logging.getLogger(__name__)

SAPIEN_SHADERS = Path(sapien.__file__).parent / "vulkan_shader"
_FILTER_FILE = "common/shadow.glsl"
_FIVE_BY_FIVE = """const int PCF_SampleCount = 25;
vec2 PCF_Samples[PCF_SampleCount] = {
  {-2, -2}, {-1, -2}, {0, -2}, {1, -2}, {2, -2},
  {-2, -1}, {-1, -1}, {0, -1}, {1, -1}, {2, -1},
  {-2, 0}, {-1, 0}, {0, 0}, {1, 0}, {2, 0},
  {-2, 1}, {-1, 1}, {0, 1}, {1, 1}, {2, 1},
  {-2, 2}, {-1, 2}, {0, 2}, {1, 2}, {2, 2}
};"""
_THREE_BY_THREE = """const int PCF_SampleCount = 9;  // datagen: 9 taps two texels apart
vec2 PCF_Samples[PCF_SampleCount] = {
  {-2, -2}, {0, -2}, {2, -2},
  {-2, 0}, {0, 0}, {2, 0},
  {-2, 2}, {0, 2}, {2, 2}
};"""
RECIPE = "pcf3x3-spacing2/1"


def patched_filter(text: str) -> str:
    """``common/shadow.glsl`` with the 3x3 table; ValueError if SAPIEN's 5x5 one is not there."""
    if text.count(_FIVE_BY_FIVE) != 1:
        raise ValueError("SAPIEN's shadow filter table is not the 5x5 one datagen replaces")
    return text.replace(_FIVE_BY_FIVE, _THREE_BY_THREE)


def pack_dir() -> Path:
    key = hashlib.sha256(f"{sapien.__version__}\n{RECIPE}".encode()).hexdigest()[:16]
    return user_cache("render") / f"shaders-{key}"


def _write_pack(target: Path) -> None:
    """Writes the pack into a new folder beside ``target`` and renames it into place (another
    process may have done the same: then its pack, the same files, stays)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".shaders-", dir=target.parent))
    try:
        for folder in ("default", "common"):
            shutil.copytree(SAPIEN_SHADERS / folder, staging / folder)
        shadow = staging / _FILTER_FILE
        shadow.write_text(patched_filter(shadow.read_text()))
        try:
            os.rename(staging, target)
        except OSError:
            if not (target / "default").is_dir():
                raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)


@functools.cache
def shader_dir() -> str:
    """The folder of the camera shaders every datagen camera uses (made on first use)."""
    target = pack_dir()
    if not (target / "default").is_dir():
        try:
            _write_pack(target)
        except (OSError, ValueError) as exc:
            log.warning("SAPIEN's own camera shaders are used (%s)", exc)
            return str(SAPIEN_SHADERS / "default")
    return str(target / "default")
