"""Users' pictures (``materials.textures_dir``, ``background.images_dir``) drawn as the library's
photographs are: a random crop, mirroring and colour jitter within the ``photos`` section's
ranges, a photograph's size on surfaces and on walls, from the randomiser's own stream; the
tile is that crop, jittered; a record made before (no crop) still draws the whole picture."""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np
import pytest

from datagen.assets.image_library import file_sha256, load_image
from datagen.assets.tabletop_layout import TRAY_CENTRE, TRAY_INNER_HALF
from datagen.assets.texture_tiles import texture_tile
from datagen.config import config_from_dict
from datagen.config.appearance import PhotosConfig
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.randomisers.photos import draw_look
from datagen.randomisers.textures import texture_surfaces
from datagen.scene_values.material import Material

PHOTOS = {  # narrow ranges, none the default: the values must come from here
    "enabled": False,  # the library's photographs off: every picture shown is the user's
    "crop": [0.3, 0.5],
    "contrast": [0.8, 0.9],
    "brightness": [0.05, 0.1],
    "saturation": [1.1, 1.2],
    "hue_deg": [10.0, 20.0],
    "surface_scale_m": [0.2, 0.25],
    "backdrop_scale_m": [2.0, 2.5],
}
LOOK = list(draw_look(np.random.default_rng(0), PhotosConfig(), 1.0, (1.0, 2.0)))


@pytest.fixture
def pictures(tmp_path):
    folder = tmp_path / "pictures"
    folder.mkdir()
    rng = np.random.default_rng(2)
    assert cv2.imwrite(str(folder / "noise.png"), rng.integers(0, 256, (48, 64, 3), np.uint8))
    assert cv2.imwrite(str(folder / "square.jpg"), rng.integers(0, 256, (40, 40, 3), np.uint8))
    return str(folder)


def _config(pictures: str, photos: dict):
    return config_from_dict(
        {
            "materials": {
                "textures_dir": pictures,
                "textures_dir_share": 1.0,
                "texture_probability": 1.0,
            },
            "background": {
                "images_dir": pictures,
                "images_dir_share": 1.0,
                "texture_probability": 1.0,
            },
            "photos": photos,
            "distractors": {"enabled": False},
        }
    )


def _shown(params: dict) -> tuple[list[dict], list[dict]]:
    """(the textures of objects, table, tray and floor; those of the walls)."""
    materials = params["materials"]
    surfaces = [*materials["objects"], *(materials[s] for s in ("table", "tray", "floor"))]
    walls = list(params["background"]["walls"].values())
    return [m.texture for m in surfaces], [w.texture for w in walls]


def _within(value: float, bounds: list[float]) -> bool:
    return bounds[0] <= value <= bounds[1]


def test_users_pictures_are_cropped_sized_and_jittered_within_the_photos_ranges(pictures):
    config = _config(pictures, PHOTOS)
    surfaces, walls = [], []
    for index in range(5):
        shown = _shown(draw_scene(config, 3, index, TRAY_CENTRE, TRAY_INNER_HALF))
        surfaces += shown[0]
        walls += shown[1]
    for values in surfaces + walls:
        assert values["family"] == "image" and list(values)[4:] == LOOK  # a photograph's keys
        x0, y0, side = values["crop"]
        assert _within(side, PHOTOS["crop"]) and 0 <= x0 <= 1 - side and 0 <= y0 <= 1 - side
        for key in ("contrast", "brightness", "saturation", "hue_deg"):
            assert _within(values[key], PHOTOS[key]), key
    assert all(_within(v["scale_m"], PHOTOS["surface_scale_m"]) for v in surfaces)
    assert all(_within(v["scale_m"], PHOTOS["backdrop_scale_m"]) for v in walls)
    assert {v["rotation_deg"] for v in walls} == {0.0}  # upright, as photographs on walls
    assert {v["flip"] for v in surfaces + walls} == {False, True}
    assert {v["path"] for v in surfaces + walls} == {"noise.png", "square.jpg"}


def test_a_distractors_picture_takes_the_photos_ranges_too(pictures):
    config = _config(pictures, PHOTOS)
    config = config.replace(distractors=replace(config.distractors, enabled=True, flying=(0, 0)))
    shown = []
    for index in range(8):
        params = draw_scene(config, 3, index, TRAY_CENTRE, TRAY_INNER_HALF)
        shown += [d["material"].texture or {} for d in params["distractors"]]
    pictures_shown = [t for t in shown if t.get("family") == "image"]
    assert pictures_shown  # texture_probability 1, textures_dir_share 1
    for values in pictures_shown:
        assert _within(values["crop"][2], PHOTOS["crop"]) and _within(
            values["hue_deg"], PHOTOS["hue_deg"]
        )
        assert _within(values["scale_m"], PHOTOS["surface_scale_m"])


def test_the_look_comes_from_the_randomisers_streams_and_changes_nothing_else(pictures):
    narrow = draw_scene(_config(pictures, PHOTOS), 3, 1, TRAY_CENTRE, TRAY_INNER_HALF)
    again = draw_scene(_config(pictures, PHOTOS), 3, 1, TRAY_CENTRE, TRAY_INNER_HALF)
    default = draw_scene(_config(pictures, {"enabled": False}), 3, 1, TRAY_CENTRE, TRAY_INNER_HALF)
    assert narrow == again
    assert _shown(narrow) != _shown(default)
    for name in ("objects", "drop_poses", "lighting", "camera", "robot"):
        assert narrow[name] == default[name]


def test_navigation_surfaces_draw_users_pictures_the_same_way(pictures):
    config = config_from_dict(
        {
            "scene": "navigation",
            "materials": {
                "textures_dir": pictures,
                "textures_dir_share": 1.0,
                "texture_probability": 1.0,
            },
            "photos": PHOTOS,
        }
    )
    plain = Material(base_color=(0.5, 0.5, 0.5, 1.0), roughness=0.5, metallic=0.0)
    drawn = texture_surfaces(
        np.random.default_rng(4), config.materials, {"floor": plain}, ("floor",), config.photos
    )
    values = drawn["floor"].texture
    assert _within(values["crop"][2], PHOTOS["crop"])
    assert _within(values["scale_m"], PHOTOS["surface_scale_m"])


def test_the_tile_is_the_crop_mirrored_and_jittered_and_an_older_record_the_whole_picture(
    pictures,
):
    values = {
        "family": "image",
        "root": pictures,
        "path": "noise.png",
        "sha256": file_sha256(pictures, "noise.png"),
        "crop": [0.25, 0.5, 0.5],
        "flip": True,
        "contrast": 1.0,
        "brightness": 0.0,
        "saturation": 1.0,
        "hue_deg": 0.0,
        "aspect": 0.75,
        "scale_m": 0.3,
        "rotation_deg": 0.0,
    }
    picture = load_image(pictures, "noise.png")  # (48, 64, 3)
    neutral = texture_tile(values)
    expected = picture[24:48, 16:48][:, ::-1]  # rows 0.5-1.0, columns 0.25-0.75, mirrored
    assert neutral.shape == expected.shape
    assert np.abs(neutral.astype(int) - expected).max() <= 1  # through float HSV and back
    brighter = texture_tile({**values, "brightness": 0.1})
    assert brighter.mean() == pytest.approx(neutral.mean() + 25.5, abs=2)
    before = {k: v for k, v in values.items() if k not in LOOK[:6]}  # a record made before
    assert np.array_equal(texture_tile(before), picture)
