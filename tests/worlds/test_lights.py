"""Light padding (datagen/worlds/realise.py, ``pad_lights``): every scene of a config has the same
light counts, so the renderer compiles its lighting shader for a handful of combinations instead
of one per scene, and the unlit lights change no byte of the picture."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import sapien

from datagen.config import load_config
from datagen.families.grasp_tabletop.world import build_scene
from datagen.sensing.render import keep_renderer_alive
from datagen.worlds.realise import light_slots

pytestmark = [pytest.mark.sim]
KINDS = {
    sapien.render.RenderDirectionalLightComponent: "directional",
    sapien.render.RenderPointLightComponent: "point",
    sapien.render.RenderSpotLightComponent: "spot",
}


def _config():
    config = load_config("configs/grasp_tabletop.yaml")
    return config.replace(render=replace(config.render, width=160, height=120))


def _counts(scene: sapien.Scene) -> tuple[tuple[str, int, int], ...]:
    """Per kind of light: how many, how many cast shadows (what SAPIEN specialises on)."""
    lights = scene.render_system.lights
    return tuple(
        (kind, sum(KINDS[type(x)] == kind for x in lights),
         sum(KINDS[type(x)] == kind and x.shadow for x in lights))
        for kind in ("directional", "point", "spot")
    )  # fmt: skip


def _colour(scene) -> np.ndarray:
    scene.scene.update_render()
    camera = scene.cameras["workspace"]
    camera.take_picture()
    return camera.get_picture("Color")


def test_every_scene_has_the_configs_light_counts_and_few_shadow_combinations():
    config = _config()
    slots = light_slots(3 + 3, 3)  # up to 3 fill spots, a soft key's 3 spots; 3 room lights
    combinations = set()
    for index in range(16):
        counts = _counts(build_scene(config, config.seed, index).scene)
        assert {kind: n for kind, n, _ in counts} == slots
        combinations.add(counts)
    # only the shadowed counts differ: the key's (0 or 1), the spots' (0..6)
    assert 3 <= len(combinations) <= 8


def test_unlit_lights_change_no_byte_of_the_picture():
    keep_renderer_alive()
    config = _config()
    for index in (0, 1, 5):
        scene = build_scene(config, config.seed, index)
        padded = _colour(scene)
        unlit = [
            light
            for light in scene.scene.render_system.lights
            if not np.any(light.color) and not light.shadow
        ]
        assert unlit  # the default draws fewer lights than its most
        for light in unlit:
            scene.scene.remove_entity(light.entity)
        assert np.array_equal(padded, _colour(scene))
