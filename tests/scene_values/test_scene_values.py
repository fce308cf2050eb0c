"""Typed scene values: drawn, written as JSON, read back as the same values; stored JSON that
is not a value is one error naming the field; a value type without a realiser fails loudly."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from datagen.config import BuildConfig, load_config
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.scene_values.arm import ArmPose, WristLook
from datagen.scene_values.bundles import tabletop_values
from datagen.scene_values.camera import CameraPose
from datagen.scene_values.checks import SceneValueError, as_json
from datagen.scene_values.lighting import Light, Lighting
from datagen.scene_values.material import Material

TRAY = ((0.08, 0.0, 0.76), (0.2, 0.26))


THREE_VIEWS = BuildConfig().replace(render=replace(BuildConfig().render, views=3))
_DEFAULT = BuildConfig()
EVERYTHING = _DEFAULT.replace(  # textures, a textured room and distractors: every material
    materials=replace(
        _DEFAULT.materials, texture_probability=0.7, class_independent_probability=0.5
    ),
    background=replace(_DEFAULT.background, enabled=True, texture_probability=0.5),
    distractors=replace(_DEFAULT.distractors, enabled=True, flying=(1, 2)),
)


@pytest.mark.parametrize(
    "config", [BuildConfig(), load_config("configs/grasp_flat.yaml"), THREE_VIEWS, EVERYTHING]
)
def test_a_drawn_scene_reads_back_from_its_json_as_the_same_values(config):
    for index in range(12):
        drawn = draw_scene(config, 3, index, *TRAY)
        stored = json.loads(json.dumps(as_json(drawn)))
        read = tabletop_values(stored)
        for name in ("lighting", "camera", "robot", "extra_views", "materials", "background"):
            assert read.get(name) == drawn.get(name), name
        for spec, read_spec in zip(
            drawn.get("distractors", []), read.get("distractors", []), strict=True
        ):
            assert read_spec["material"] == spec["material"]
        assert as_json(read) == stored
    assert config.render.views == 1 or len(drawn["extra_views"]) == config.render.views - 1


def test_the_lights_of_every_kind_keep_their_fields_and_only_those():
    key = Light("directional", (1.0, 0.9, 0.8), 2.0, True, direction=(0, 0, -1.0))
    soft = Light("directional", (1, 1, 1), 1.5, True, (0, 0, -1), shadow_edge="soft",
                 area_radius_m=0.2)  # fmt: skip
    spot = Light("spot", (1, 1, 1), 1.0, False, (0, 0, -1), (0, 0, 2), 4500.0, outer_fov_deg=60)
    point = Light("point", (1, 1, 1), 0.5, False, position=(1, 2, 2.5))
    lighting = Lighting(0.2, (key, soft, spot, point), target=(0, 0, 0.8))
    stored = lighting.to_json()
    assert set(stored["lights"][0]) == {"type", "colour", "intensity", "shadow", "direction"}
    assert set(stored["lights"][3]) == {"type", "colour", "intensity", "shadow", "position"}
    assert Lighting.from_json(json.loads(json.dumps(stored))) == lighting


@pytest.mark.parametrize(
    ("stored", "message"),
    [
        ({"ambient": 0.1}, r"randomisation\.lighting: missing lights"),
        ({"ambient": -1, "lights": []}, r"lighting\.ambient: expected a number in \[0, inf\]"),
        ({"ambient": 0.1, "lights": [], "sun": 1}, r"randomisation\.lighting: unknown key\(s\) 'sun'"),
        ({"ambient": 0.1, "lights": [{"type": "laser", "colour": [1, 1, 1], "intensity": 1, "shadow": False}]},
         r"lights\[0\]\.type: expected one of \['directional', 'spot', 'point'\], got 'laser'"),
        ({"ambient": 0.1, "lights": [{"type": "point", "colour": [1, 1, 1], "intensity": 1, "shadow": False}]},
         r"lights\[0\]: a point light needs position"),
        ({"ambient": 0.1, "lights": [{"type": "point", "colour": [1, "x", 1], "intensity": 1, "shadow": False, "position": [0, 0, 1]}]},
         r"lights\[0\]\.colour\[1\]: expected a finite number, got 'x'"),
        ({"ambient": 0.1, "lights": [{"type": "point", "colour": [1, 1, 1], "intensity": 1e999, "shadow": False, "position": [0, 0, 1]}]},
         r"lights\[0\]\.intensity: expected a finite number, got inf"),
        ({"ambient": 0.1, "lights": [None] * 65}, r"lights: expected a list of at most 64 lights"),
    ],
)  # fmt: skip
def test_stored_lighting_that_is_not_lighting_is_one_error_naming_the_field(stored, message):
    with pytest.raises(SceneValueError, match=message):
        Lighting.from_json(stored)


def test_stored_cameras_and_arm_poses_are_checked_field_by_field():
    with pytest.raises(SceneValueError, match=r"camera\.fovy_deg: expected a number in \[0, 180\]"):
        CameraPose.from_json({"eye": [0, 0, 1], "target": [0, 0, 0], "fovy_deg": 400})
    with pytest.raises(SceneValueError, match=r"camera\.eye: expected 3 numbers"):
        CameraPose.from_json({"eye": [0, 1], "target": [0, 0, 0], "fovy_deg": 40})
    with pytest.raises(SceneValueError, match=r"robot\.qpos: expected a list of 1-64 joint"):
        ArmPose.from_json({"qpos": []})
    with pytest.raises(SceneValueError, match=r"robot\.look: missing up"):
        ArmPose.from_json({"qpos": [0.1], "look": {"eye": [0, 0, 1], "target": [0, 0, 0]}})
    with pytest.raises(SceneValueError, match=r"extra_views: expected an object"):
        stored = as_json(draw_scene(BuildConfig(), 0, 0, *TRAY)) | {"extra_views": [1]}
        tabletop_values(stored)
    pose = ArmPose((0.1, 0.2), WristLook((0, 0, 1), (0, 0, 0), (1, 0, 0)))
    assert ArmPose.from_json(json.loads(json.dumps(pose.to_json()))) == pose


def test_a_value_type_without_a_usd_realiser_is_an_error():
    pytest.importorskip("pxr")
    from pxr import Usd

    from datagen.exports.usd_stage import add_to_stage

    stage = Usd.Stage.CreateInMemory()
    add_to_stage(Lighting(0.3, ()), stage)  # a type with a realiser: the ambient dome
    assert stage.GetPrimAtPath("/World/Lights/ambient").IsValid()
    with pytest.raises(TypeError, match="no USD realiser for scene values of type CameraPose"):
        add_to_stage(CameraPose((0, 0, 1), (0, 0, 0), 40.0), stage)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            lambda m: m.update(base_color=[0.5, 0.5, 2.0, 1.0]),
            "table.base_color[2]: expected a number in [0, 1]",
        ),
        (lambda m: m.update(base_color=[0.5, 0.5, 0.5]), "table.base_color: expected 4 numbers"),
        (lambda m: m.pop("roughness"), "table: missing roughness"),
        (lambda m: m.update(metallic=float("nan")), "table.metallic: expected a finite number"),
        (lambda m: m.update(texture=["marble"]), "table.texture: expected an object"),
        (lambda m: m.update(texture={"scale_m": 1.0}), "table.texture.family: expected"),
        (lambda m: m.update(emission=1.0), "table: unknown key(s) 'emission'"),
    ],
)
def test_a_stored_material_that_is_not_one_is_one_error_naming_the_field(change, message):
    stored = json.loads(json.dumps(as_json(draw_scene(EVERYTHING, 3, 0, *TRAY))))
    change(stored["materials"]["table"])
    with pytest.raises(SceneValueError) as error:
        tabletop_values(stored)
    assert f"randomisation.materials.{message}" in str(error.value)


def test_a_material_writes_its_fields_in_the_order_the_samples_store_them():
    plain = Material(base_color=(0.1, 0.2, 0.3, 1.0), roughness=0.4, metallic=0.0)
    textured = plain.with_texture({"family": "marble", "scale_m": 0.3})
    assert list(plain.to_json()) == ["base_color", "roughness", "metallic"]
    assert list(textured.to_json()) == ["base_color", "roughness", "metallic", "texture"]
    assert Material.from_json(json.loads(json.dumps(textured.to_json()))) == textured
    with pytest.raises(SceneValueError, match=r"material\.roughness"):
        Material(base_color=(0.1, 0.2, 0.3, 1.0), roughness=1.5, metallic=0.0)
