"""Class-independent colours (datagen/randomisers/materials.py, ``class_free_colours``): with
``materials.class_independent_probability`` per scene (stream ``colours``) the table, tray,
floor, walls and objects draw their colours from one distribution, so colour statistics no
longer tell them apart; procedural textures follow the new colours; probability 0 leaves every
value as it was."""

from __future__ import annotations

import colorsys
import dataclasses
import re

import numpy as np
import pytest
from scipy.stats import ks_2samp

from datagen.assets.tabletop_layout import TRAY_CENTRE, TRAY_INNER_HALF
from datagen.config import BuildConfig
from datagen.config.appearance import PhotosConfig
from datagen.config.sections import MaterialsConfig
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.randomisers.background import draw_background
from datagen.randomisers.materials import (
    CLASS_FREE_SATURATION,
    CLASS_FREE_VALUE,
    class_free_colours,
    draw_materials,
)
from datagen.randomisers.textures import add_textures
from datagen.scene_values.material import Material
from datagen.seeding import sample_rng

ALWAYS = MaterialsConfig(class_independent_probability=1.0)
NEVER = MaterialsConfig(class_independent_probability=0.0)
NO_PHOTOS = PhotosConfig(enabled=False)  # these tests look at colours and procedural textures


def _drawn(index: int, cfg: MaterialsConfig, objects: int = 4) -> dict:
    """A scene's materials and room, drawn as ``draw_scene`` draws them (photos off)."""
    rng = np.random.default_rng(index)
    materials = add_textures(rng, cfg, draw_materials(rng, cfg, objects))
    background = draw_background(rng, BuildConfig().background, cfg, TRAY_CENTRE)
    return {"materials": materials, "background": background}


def _every(scene: dict) -> list[Material]:
    """Every material of the scene: objects, table, tray, floor, walls."""
    materials = scene["materials"]
    surfaces = [materials[surface] for surface in ("table", "tray", "floor")]
    return [*materials["objects"], *surfaces, *scene["background"]["walls"].values()]


def _hsv(material: Material) -> tuple[float, float, float]:
    return colorsys.rgb_to_hsv(*material.base_color[:3])


def _by_class(cfg: MaterialsConfig, scenes: int) -> dict[str, np.ndarray]:
    """(N, 3) HSV of each class's base colours over ``scenes`` scenes."""
    colours: dict[str, list] = {"object": [], "table": [], "tray": [], "floor": [], "wall": []}
    for index in range(scenes):
        scene = class_free_colours(np.random.default_rng(10_000 + index), cfg, _drawn(index, cfg))
        colours["object"] += [_hsv(m) for m in scene["materials"]["objects"]]
        for surface in ("table", "tray", "floor"):
            colours[surface].append(_hsv(scene["materials"][surface]))
        colours["wall"] += [_hsv(m) for m in scene["background"]["walls"].values()]
    return {name: np.asarray(values) for name, values in colours.items()}


def test_with_probability_1_every_class_has_the_same_colour_statistics():
    colours = _by_class(ALWAYS, 400)
    for name, hsv in colours.items():
        assert hsv[:, 1].min() >= CLASS_FREE_SATURATION[0] - 1e-6
        assert CLASS_FREE_VALUE[0] - 1e-6 <= hsv[:, 2].min() and hsv[:, 2].max() <= 1.0 + 1e-6
        for other in ("object", "table", "tray"):
            if other == name:
                continue
            for channel in range(3):  # hue, saturation, value
                p = ks_2samp(hsv[:, channel], colours[other][:, channel]).pvalue
                assert p > 1e-3, f"{name} vs {other}, HSV channel {channel}: p = {p:.2g}"
    # the same test tells the classes apart with the colours as they are drawn otherwise
    before = _by_class(NEVER, 400)
    assert ks_2samp(before["table"][:, 1], before["object"][:, 1]).pvalue < 1e-6
    assert ks_2samp(before["tray"][:, 2], before["object"][:, 2]).pvalue < 1e-6


def test_procedural_textures_follow_the_new_colours_and_pictures_stay():
    for index in range(20):
        drawn = _drawn(
            index, MaterialsConfig(texture_probability=1.0, class_independent_probability=1.0)
        )
        scene = class_free_colours(np.random.default_rng(index), ALWAYS, drawn)
        for before, after in zip(_every(drawn), _every(scene), strict=True):
            if before.texture is None:  # a wall (background.texture_probability)
                continue
            texture, was = after.texture, before.texture
            assert texture is not None
            assert texture["palette"][0] == list(after.base_color[:3])  # around its own colour
            assert {k: v for k, v in texture.items() if k != "palette"} == {
                k: v for k, v in was.items() if k != "palette"
            }  # the same pattern, seed, scale and rotation
            assert after.roughness == before.roughness
    picture = {"family": "photo", "path": "p.jpg", "sha256": "0" * 64, "scale_m": 0.2}
    params = _drawn(0, NEVER)
    params["materials"]["table"] = params["materials"]["table"].with_texture(picture)
    recoloured = class_free_colours(np.random.default_rng(0), ALWAYS, params)
    assert recoloured["materials"]["table"].texture == picture


def test_probability_0_leaves_the_values_exactly_as_before_and_the_draw_is_per_scene():
    params = _drawn(3, NEVER)
    assert class_free_colours(np.random.default_rng(0), NEVER, params) is params
    never = BuildConfig(materials=NEVER, photos=NO_PHOTOS)
    for index in range(3):
        scene = draw_scene(never, 5, index, TRAY_CENTRE, TRAY_INNER_HALF)
        rng = sample_rng(5, index, "materials")
        materials = draw_materials(rng, never.materials, len(scene["objects"]))
        assert scene["materials"] == add_textures(
            sample_rng(5, index, "textures"), never.materials, materials
        )
        background = draw_background(
            sample_rng(5, index, "background"), never.background, never.materials, TRAY_CENTRE
        )
        assert scene["background"] == background
    # with 0.5, some scenes are recoloured and some are not; the rest of a scene is the same
    half = dataclasses.replace(never, materials=MaterialsConfig(class_independent_probability=0.5))
    changed = []
    for index in range(16):
        a = draw_scene(never, 5, index, TRAY_CENTRE, TRAY_INNER_HALF)
        b = draw_scene(half, 5, index, TRAY_CENTRE, TRAY_INNER_HALF)
        changed.append(a["materials"] != b["materials"])
        for key in a.keys() - {"materials", "background"}:
            assert a[key] == b[key]
        assert a["background"]["room"] == b["background"]["room"]
    assert 3 <= sum(changed) <= 13


def test_a_wrong_probability_is_named():
    from datagen.config import config_from_dict
    from datagen.errors import ConfigError

    expected = "materials.class_independent_probability: expected values in [0.0, 1.0]"
    with pytest.raises(ConfigError, match=re.escape(expected)):
        config_from_dict({"materials": {"class_independent_probability": 1.5}}, source="my.yaml")
