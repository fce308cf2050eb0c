"""The wider lighting: black-body colour temperatures, ranges over many draws, soft shadows that
render a wider penumbra than hard ones, and configs written before these keys."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import sapien

from datagen.config import config_from_dict
from datagen.config.sections import LightingConfig
from datagen.geometry import look_at
from datagen.randomisers.lighting import draw_lighting, kelvin_to_rgb
from datagen.scene_values.lighting import Light, Lighting
from datagen.sensing.render import capture, keep_renderer_alive
from datagen.worlds.realise import apply_lighting

TARGET = (0.0, 0.0, 0.85)
NO_PHOTOS = {"photos": {"enabled": False}}  # the photo library need not be installed


def test_6500_k_is_white_and_2700_k_is_redder_than_8000_k():
    assert kelvin_to_rgb(6500.0).tolist() == [1.0, 1.0, 1.0]
    ratios = [kelvin_to_rgb(k)[0] / kelvin_to_rgb(k)[2] for k in range(2000, 12001, 500)]
    assert all(a > b for a, b in itertools.pairwise(ratios)), "red/blue falls with K"
    warm, cool = kelvin_to_rgb(2700.0), kelvin_to_rgb(8000.0)
    assert warm[0] == 1.0 and warm[2] < 0.3 and cool[2] == 1.0 and cool[0] < 0.9


def test_6500_k_without_jitter_gives_exactly_white_light():
    cfg = LightingConfig(colour_temperature_k=(6500, 6500), colour_temperature_jitter=0.0)
    for seed in range(5):
        for light in draw_lighting(np.random.default_rng(seed), cfg, TARGET).lights:
            assert light.colour == (1.0, 1.0, 1.0) and light.temperature_k == 6500


def test_draws_stay_within_the_configured_ranges():
    cfg = LightingConfig()
    edges, kelvins = [], []
    for seed in range(400):
        values = draw_lighting(np.random.default_rng(seed), cfg, TARGET)
        assert cfg.ambient[0] <= values.ambient <= cfg.ambient[1]
        assert cfg.lights[0] <= len(values.lights) <= cfg.lights[1]
        for light in values.lights:
            assert cfg.intensity[0] <= light.intensity <= cfg.intensity[1]
            kelvins.append(light.temperature_k)
            assert max(light.colour) == 1.0 and min(light.colour) >= 0.0
            elevation = np.degrees(np.arcsin(-light.direction[2]))
            assert cfg.elevation_deg[0] - 1e-3 <= elevation <= cfg.elevation_deg[1] + 1e-3
        key = values.lights[0]
        edges.append(key.shadow_edge)
        if key.shadow_edge == "soft":
            assert cfg.soft_shadow_radius_m[0] <= key.area_radius_m <= cfg.soft_shadow_radius_m[1]
    assert min(kelvins) >= 2700 and max(kelvins) <= 8000
    assert np.ptp(kelvins) > 4500, "the whole temperature range is drawn"
    assert 0.4 < edges.count("soft") / len(edges) < 0.6


def test_configs_without_the_new_keys_load_and_bad_ranges_are_refused():
    old = {"lighting": {"ambient": [0.15, 0.45], "lights": [1, 3], "intensity": [0.6, 2.0],
                        "elevation_deg": [35, 85], "colour_temperature_jitter": 0.15,
                        "shadows": True}}  # fmt: skip
    cfg = config_from_dict({**old, **NO_PHOTOS}).lighting
    assert cfg.colour_temperature_k == (2700, 8000) and cfg.soft_shadow_probability == 0.5
    off = config_from_dict({"lighting": {"shadows": False}, **NO_PHOTOS}).lighting
    assert not draw_lighting(np.random.default_rng(0), off, TARGET).lights[0].shadow
    for key, value, expected in [
        ("colour_temperature_k", [500, 8000], "expected values in [1000.0, 40000.0]"),
        ("colour_temperature_k", [8000, 2700], "expected [min, max] with min <= max"),
        ("soft_shadow_probability", 1.5, "expected values in [0.0, 1.0]"),
        ("soft_shadow_radius_m", [0.1, 2.0], "expected values in [0.01, 0.5]"),
    ]:
        with pytest.raises(ValueError, match=rf"lighting\.{key}: {expected}".replace("[", r"\[")):
            config_from_dict({"lighting": {key: value}, **NO_PHOTOS})


def _shadow_profile(edge: str) -> np.ndarray:
    """Grey level along an image row across the shadow a 10 cm box on a plane casts under a
    key light at 45 degrees elevation (ambient 0.1), viewed from straight above."""
    keep_renderer_alive()
    scene = sapien.Scene()
    grey = sapien.render.RenderMaterial(base_color=[0.8, 0.8, 0.8, 1], roughness=0.9)
    for half, centre in [([1.0, 1.0, 0.01], [0, 0, 0.84]), ([0.05, 0.05, 0.05], [0, 0, 0.9])]:
        builder = scene.create_actor_builder()
        builder.add_box_visual(half_size=half, material=grey)
        builder.build_static().set_pose(sapien.Pose(centre))
    key = Light("directional", (1, 1, 1), 2.0, True, direction=(-0.707107, 0, -0.707107),
                shadow_edge=edge, area_radius_m=0.25)  # fmt: skip
    apply_lighting(Lighting(0.1, (key,), target=tuple(TARGET)), scene, 1024)
    camera = scene.add_camera("top", 320, 240, np.deg2rad(50), 0.05, 5.0)
    camera.entity.set_pose(sapien.Pose(look_at([0.0, -0.01, 1.6], TARGET)))
    scene.update_render()
    return capture(camera).rgb[120].mean(axis=1)  # the row through the box; +x is to the right


def _edge_width_px(row: np.ndarray) -> int:
    """Pixels of the shadow's outer edge (left of the umbra) between 10 % and 90 % of the way
    from the umbra's level to the lit plane's level next to it."""
    umbra = int(np.argmin(row[:160]))
    outer = row[: umbra + 1][::-1]  # from the umbra outwards
    lo, hi = row[umbra], outer[min(len(outer) - 1, 60)]
    levels = (outer - lo) / max(hi - lo, 1e-6)
    return int(np.argmax(levels > 0.9) - np.argmax(levels > 0.1))


@pytest.mark.sim
def test_a_soft_shadow_has_a_wider_edge_than_a_hard_one():
    hard, soft = _shadow_profile("hard"), _shadow_profile("soft")
    assert hard.min() < 0.6 * hard.max() and soft.min() < 0.6 * soft.max(), "both cast a shadow"
    assert _edge_width_px(soft) >= 2 * _edge_width_px(hard) + 4, (
        _edge_width_px(soft),
        _edge_width_px(hard),
    )
