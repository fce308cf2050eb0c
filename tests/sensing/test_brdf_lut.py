"""The BRDF table cached per machine (datagen/sensing/brdf_lut.py): a camera given it renders
the bytes a camera that computes SAPIEN's own renders; a torn cache file is read back again."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from datagen.config import load_config

pytestmark = [pytest.mark.sim, pytest.mark.slow]  # SAPIEN computes its own table: ~4 s


def test_a_camera_with_the_cached_table_renders_what_sapiens_own_table_renders(tmp_path):
    """Two cameras at one pose in the default grasp scene (textures, photographs, metal and
    rough surfaces, several lights): one with the cached table, one computing SAPIEN's. The
    table weighs the light of an environment map (datagen's scenes have none, so there it
    changes nothing): the scene gets a bright one here, so a wrong table changes pixels."""
    import cv2
    import sapien

    from datagen.families.grasp_tabletop.world import build_scene
    from datagen.sensing.brdf_lut import LUT_SIZE, cache_file
    from datagen.sensing.cameras import twin_camera
    from datagen.sensing.shader_pack import shader_dir

    config = load_config("configs/grasp_tabletop.yaml")
    config = config.replace(render=replace(config.render, width=160, height=120))
    scene = build_scene(config, config.seed, 5)  # its cameras get the cached table
    faces = []
    for i, name in enumerate(("px", "nx", "py", "ny", "pz", "nz")):
        face = np.full((32, 32, 3), (60 + 30 * i, 250 - 30 * i, 120 + 20 * i), np.uint8)
        cv2.imwrite(str(tmp_path / f"{name}.png"), face)
        faces.append(str(tmp_path / f"{name}.png"))
    scene.scene.render_system.cubemap = sapien.render.RenderCubemap(*faces)
    cached = scene.cameras["workspace"]
    own = twin_camera(scene.scene, cached, shader_dir())  # computes SAPIEN's table
    scene.scene.update_render()
    pictures = []
    for camera in (cached, own):
        camera.take_picture()
        pictures.append(camera.get_picture("Color"))
    assert np.array_equal(pictures[0], pictures[1])
    assert pictures[0][..., :3].std() > 0.05  # a scene, not a blank picture

    table = np.load(cache_file())
    assert table.shape == (LUT_SIZE, LUT_SIZE, 2) and table.dtype == np.float16
    assert np.isfinite(table).all() and table.min() >= 0.0 and table.max() < 2.0


def test_a_torn_cache_file_is_read_back_again(tmp_path):
    code = """
import numpy as np, sapien
from datagen.sensing import brdf_lut
path = brdf_lut.cache_file()
path.parent.mkdir(parents=True)
path.write_bytes(b"torn")
scene = sapien.Scene()
camera = scene.add_camera("c", 8, 8, 1.0, 0.01, 1.0)
brdf_lut.attach_brdf_lut(camera)
scene.update_render(); camera.take_picture(); camera.get_picture("Color")
assert np.array_equal(np.load(path), brdf_lut.read_back_default_lut())
print("ok", path)
"""
    done = subprocess.run(
        [sys.executable, "-c", code],
        env=os.environ | {"XDG_CACHE_HOME": str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith(f"ok {tmp_path}/datagen/render/brdf_lut-")
