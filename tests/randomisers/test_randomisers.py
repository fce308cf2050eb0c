"""Randomisers are pure samplers: same (seed, index) -> same values; named streams are independent."""

import json

import numpy as np

from datagen.assets.shapes import build_geometry
from datagen.config import BuildConfig
from datagen.config.sections import ObjectsConfig
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.randomisers.objects import draw_objects
from datagen.scene_values.checks import as_json
from datagen.seeding import sample_rng

TRAY = ((0.08, 0.0, 0.76), (0.2, 0.26))


def test_same_seed_and_index_give_identical_values():
    a = draw_scene(BuildConfig(), 5, 17, *TRAY)
    b = draw_scene(BuildConfig(), 5, 17, *TRAY)
    assert json.dumps(as_json(a), sort_keys=True) == json.dumps(as_json(b), sort_keys=True)


def test_other_index_or_seed_gives_other_values():
    base = json.dumps(as_json(draw_scene(BuildConfig(), 5, 17, *TRAY)), sort_keys=True)
    assert json.dumps(as_json(draw_scene(BuildConfig(), 5, 18, *TRAY)), sort_keys=True) != base
    assert json.dumps(as_json(draw_scene(BuildConfig(), 6, 17, *TRAY)), sort_keys=True) != base


def test_streams_are_independent_of_each_other():
    """Changing the object config must not change the lighting, camera or robot draws (the
    wrist camera's look-at point follows the objects; its height and roll are the robot's)."""
    config = BuildConfig()
    fewer = config.replace(objects=ObjectsConfig(count=(1, 1)))
    a, b = draw_scene(config, 0, 3, *TRAY), draw_scene(fewer, 0, 3, *TRAY)
    assert a["lighting"] == b["lighting"]
    assert a["camera"] == b["camera"]
    assert a["robot"].qpos == b["robot"].qpos
    looks = a["robot"].look, b["robot"].look
    assert looks[0].up == looks[1].up and looks[0].eye[2] == looks[1].eye[2]
    assert looks[0].target != looks[1].target


def test_values_are_json_and_within_config_ranges():
    config = BuildConfig()
    for index in range(30):
        values = draw_scene(config, 1, index, *TRAY)
        json.dumps(as_json(values))
        assert config.objects.count[0] <= len(values["objects"]) <= config.objects.count[1]
        assert (
            len(values["drop_poses"])
            == len(values["objects"])
            == len(values["materials"]["objects"])
        )
        assert (
            config.lighting.lights[0] <= len(values["lighting"].lights) <= config.lighting.lights[1]
        )
        assert config.camera.fovy_deg[0] <= values["camera"].fovy_deg <= config.camera.fovy_deg[1]
        for obj in values["objects"]:
            assert config.objects.density[0] <= obj["density"] <= config.objects.density[1]
            assert config.objects.friction[0] <= obj["friction"] <= config.objects.friction[1]


def test_every_family_builds_convex_parts_of_the_requested_size():
    config = ObjectsConfig()
    for family in config.families:
        objects = draw_objects(
            sample_rng(0, 0, family), ObjectsConfig(count=(4, 4), families=(family,))
        )
        for obj in objects:
            geometry = build_geometry(obj["shape"])
            assert all(part.is_convex for part in geometry.parts)
            extent = float(np.max(geometry.visual.extents))
            assert extent <= config.size[1] * 1.3, (family, extent)
            assert np.all(geometry.obb_extents > 0)
