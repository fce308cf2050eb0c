"""Backdrop rooms and textured scenes on the real renderer (tiny images): walls labelled
``wall``, lit under a ceiling, rebuilt identically from the stored values; and a real build
with users' picture folders (bad files skipped and listed), exported to USD with its tiles and
replayed pixel for pixel."""

from __future__ import annotations

import json
from dataclasses import replace

import cv2
import numpy as np
import pytest

from datagen.assets.tabletop_layout import TRAY_CENTRE, TRAY_INNER_HALF
from datagen.config import config_from_dict
from datagen.dataset.loader import load, read_manifest
from datagen.families.grasp_tabletop.produce import annotate_scene
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.families.grasp_tabletop.world import CLASSES, build_scene, construct_scene
from datagen.pipeline.run import run_build
from datagen.scene_values.bundles import tabletop_values
from datagen.scene_values.checks import as_json
from datagen.sensing.render import capture, keep_renderer_alive

TINY = {"render": {"width": 64, "height": 48}, "objects": {"count": [1, 2]}}
# everything but the room off: these tests look at walls and textures only
QUIET = {"distractors": {"enabled": False}, "camera_effects": {"enabled": False}}
LOOK_AT_THE_WALL = {  # from above the table towards the +x wall, 1.5 m away
    "camera": {"eye": [0.0, 0.0, 1.4], "target": [1.0, 0.0, 1.4], "eye_jitter": 0.0,
               "target_jitter": 0.0, "fovy_deg": [40, 40]},
    "background": {"room_half_size": [1.5, 1.5], "wall_height": [2.6, 2.6]},
}  # fmt: skip


def _config(*overrides):
    data: dict = {}
    for override in (TINY, QUIET, *overrides):
        for section, values in override.items():
            data[section] = {**data.get(section, {}), **values}
    return config_from_dict(data)


def _render(config, seed=1, index=0):
    keep_renderer_alive()
    scene = build_scene(config, seed, index)
    return annotate_scene(scene, config, seed, index, cameras=("workspace",))


@pytest.mark.sim
def test_walls_are_drawn_textured_and_labelled_wall():
    config = _config(LOOK_AT_THE_WALL, {"background": {"texture_probability": 1.0}})
    annotated = _render(config)
    view = annotated.views["workspace"]
    wall = view.semantic == CLASSES.index("wall")
    assert wall.mean() > 0.9, "the camera faces the +x wall"
    assert annotated.metadata["classes"][CLASSES.index("wall")] == "wall"
    assert "texture" in annotated.metadata["randomisation"]["background"]["walls"]["x_max"]
    assert view.rgb[wall].std(axis=0).max() > 3, "a textured wall, not a flat colour"
    depth = view.depth[wall]  # millimetres: the wall is 1.5 m away along the view
    assert np.median(depth) == pytest.approx(1500, abs=50)


@pytest.mark.sim
def test_background_off_adds_no_wall_and_no_stored_room():
    config = _config(LOOK_AT_THE_WALL, {"background": {"enabled": False}})
    annotated = _render(config)
    assert "background" not in annotated.metadata["randomisation"]
    assert not (annotated.views["workspace"].semantic == CLASSES.index("wall")).any()


@pytest.mark.sim
def test_a_ceiling_does_not_put_the_table_in_the_key_lights_shadow():
    def table_brightness(ceiling):
        config = _config(
            {"background": {"ceiling_probability": ceiling, "room_lights": [0, 0],
                            "texture_probability": 0.0},
             "materials": {"texture_probability": 0.0},
             "lighting": {"lights": [1, 1], "ambient": [0.1, 0.1]}}
        )  # fmt: skip
        view = _render(config).views["workspace"]
        table = np.isin(view.semantic, [CLASSES.index("table"), CLASSES.index("tray")])
        return view.rgb[table].mean()

    assert table_brightness(1.0) > 0.9 * table_brightness(0.0)


@pytest.mark.sim
def test_a_textured_scene_is_rebuilt_identically_from_its_stored_values():
    config = _config({"materials": {"texture_probability": 1.0, "normal_maps": True}})
    keep_renderer_alive()
    params = draw_scene(config, 4, 3, TRAY_CENTRE, TRAY_INNER_HALF)
    stored = tabletop_values(json.loads(json.dumps(as_json(params))))  # as a replay reads them

    def image(values):
        scene = construct_scene(config, values)
        scene.scene.update_render()
        return capture(scene.cameras["workspace"]).rgb

    first = image(params)
    assert np.array_equal(first, image(stored))
    assert not np.array_equal(first, image(_untextured(stored))), "the textures show"


def _untextured(params):
    def plain(material):
        return replace(material, texture=None)

    materials = {k: plain(v) for k, v in params["materials"].items() if k != "objects"}
    materials["objects"] = [plain(m) for m in params["materials"]["objects"]]
    return {**params, "materials": materials}


def _pictures(folder, bad_name, bad_bytes):
    folder.mkdir()
    rng = np.random.default_rng(1)
    assert cv2.imwrite(str(folder / "good.png"), rng.integers(0, 256, (24, 40, 3), dtype=np.uint8))
    (folder / bad_name).write_bytes(bad_bytes)


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_build_with_picture_folders_lists_skips_exports_tiles_and_replays(tmp_path):
    from pxr import Usd, UsdGeom, UsdShade

    from datagen.tools.replay import replay_differences

    _pictures(tmp_path / "textures", "broken.jpg", b"\xff\xd8\xff not a jpeg")
    _pictures(tmp_path / "walls", "readme.txt", b"backdrops")
    config = _config(
        {"materials": {"textures_dir": str(tmp_path / "textures"), "texture_probability": 1.0,
                       "textures_dir_share": 1.0},
         "background": {"images_dir": str(tmp_path / "walls"), "texture_probability": 1.0,
                        "images_dir_share": 1.0},
         "output": {"formats": ["webdataset", "usd"]},
         "photos": {"enabled": False}},  # the users' pictures, not the library's, on every surface
    ).replace(num_samples=2, seed=3)  # fmt: skip
    out = tmp_path / "built"
    run_build(config, out, workers=1)
    pictures = read_manifest(out)["pictures"]
    assert pictures["materials.textures_dir"]["skipped"][0]["path"] == "broken.jpg"
    assert pictures["background.images_dir"]["skipped"] == [
        {"path": "readme.txt", "reason": "not a PNG or JPEG file (.txt)"}
    ]
    dataset = load(out)
    key = dataset.keys[0]
    stage = Usd.Stage.Open(str(out / "usd" / f"{key}.usda"))
    table = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/Table/top/part_0")).GetPrimvar("st")
    assert table and len(table.Get()) == 12 * 3  # face-varying: a coordinate per corner
    tile = UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/table/tile"))
    asset = tile.GetInput("file").Get().path
    written = cv2.imread(str(out / "usd" / asset))
    table_texture = dataset[0]["meta"]["randomisation"]["materials"]["table"]["texture"]
    side = table_texture["crop"][2]  # the user's picture, cropped as a photograph, beside the stage
    assert abs(written.shape[0] - side * 24) <= 1 and abs(written.shape[1] - side * 40) <= 1
    assert stage.GetPrimAtPath("/World/Background/wall_x_max").IsValid()
    for name, (_, _, diff) in replay_differences(out, key).items():
        assert (diff == 0).mean() > 0.999 and (diff > 2).mean() <= 5e-4, name
