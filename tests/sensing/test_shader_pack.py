"""datagen's camera shaders (datagen/sensing/shader_pack.py): SAPIEN's with a 3x3 shadow filter.
Only shadow edges change: a scene without shadows renders the same bytes as with SAPIEN's own
pack, a shadowed one differs by a few levels on a few per cent of its pixels."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from datagen.config import load_config
from datagen.families.grasp_tabletop.world import build_scene
from datagen.sensing import shader_pack
from datagen.sensing.cameras import twin_camera
from datagen.sensing.render import keep_renderer_alive


def test_the_filter_table_is_replaced_once_or_refused():
    original = (shader_pack.SAPIEN_SHADERS / "common" / "shadow.glsl").read_text()
    patched = shader_pack.patched_filter(original)
    assert "PCF_SampleCount = 9;" in patched and "PCF_SampleCount = 25;" not in patched
    assert patched.replace(shader_pack._THREE_BY_THREE, shader_pack._FIVE_BY_FIVE) == original
    with pytest.raises(ValueError, match="5x5"):
        shader_pack.patched_filter(patched)


@pytest.mark.sim
def test_the_pack_is_sapiens_default_with_the_filter_patched():
    pack = Path(shader_pack.shader_dir())
    sapien_default = shader_pack.SAPIEN_SHADERS / "default"
    assert sorted(p.name for p in pack.iterdir()) == sorted(
        p.name for p in sapien_default.iterdir()
    )
    for name in ("deferred.frag", "gbuffer.frag", "composite0.frag"):
        assert (pack / name).read_text() == (sapien_default / name).read_text()
    assert "PCF_SampleCount = 9;" in (pack.parent / "common" / "shadow.glsl").read_text()


def _pictures(config, index: int, shader_dir: str) -> np.ndarray:
    scene = build_scene(config, config.seed, index)
    workspace = scene.cameras["workspace"]
    camera = twin_camera(scene.scene, workspace, shader_dir)
    scene.scene.update_render()
    pictures = []
    for cam in (workspace, camera):
        cam.take_picture()
        pictures.append(np.round(np.clip(cam.get_picture("Color")[..., :3], 0, 1) * 255))
    return np.stack(pictures)


@pytest.mark.sim
def test_only_shadow_edges_change():
    keep_renderer_alive()
    config = load_config("configs/grasp_tabletop.yaml")
    config = config.replace(render=replace(config.render, width=320, height=240))
    sapiens = str(shader_pack.SAPIEN_SHADERS / "default")
    changed = []
    for index in (0, 1, 6):
        ours, theirs = _pictures(config, index, sapiens)
        difference = np.abs(ours - theirs).max(axis=-1)
        changed.append(np.mean(difference > 1))
        assert difference.max() <= 60  # levels of 255: a penumbra's edge, never a new shadow
    assert 0.002 < np.mean(changed) < 0.06
    shadowless = config.replace(lighting=replace(config.lighting, shadows=False))
    ours, theirs = _pictures(shadowless, 0, sapiens)
    assert np.array_equal(ours, theirs)
