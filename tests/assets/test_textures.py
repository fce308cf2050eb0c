"""Procedural textures, texture coordinates and users' texture folders: pure functions (no
marker), the textured scene on the real renderer (``sim``), and bad picture folders through
the real CLI (exit 2, one line)."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh
import yaml

from datagen.assets.image_library import ImageFolderError, check_picture, load_image, load_library
from datagen.assets.tabletop_layout import TRAY_CENTRE, TRAY_INNER_HALF
from datagen.assets.texture_tiles import (
    TEXTURE_FAMILIES,
    apply_palette,
    draw_texture,
    pattern,
    surface_uv,
    texture_tile,
)
from datagen.assets.uv_mapping import box_mapped
from datagen.config import config_from_dict
from datagen.errors import ConfigError
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.scene_values.checks import as_json
from datagen.seeding import sample_rng

RED = [0.8, 0.1, 0.1, 1.0]


@pytest.mark.parametrize("family", TEXTURE_FAMILIES)
def test_every_family_is_a_seeded_periodic_tile_in_unit_range(family):
    field = pattern(family, 7)
    assert field.shape == (128, 128) and field.min() >= 0.0 and field.max() <= 1.0
    assert field.std() > 0.05, "a pattern, not a flat colour"
    assert np.array_equal(field, pattern(family, 7))
    assert not np.array_equal(field, pattern(family, 8))
    # it repeats without a seam: the last and first columns (rows) differ no more than the
    # most different neighbouring columns (rows) inside the tile
    for axis in (0, 1):
        inside = np.abs(np.diff(field, axis=axis)).mean(axis=1 - axis).max()
        seam = np.abs(field.take(0, axis) - field.take(-1, axis)).mean()
        assert seam <= inside + 1e-9, axis


def test_texture_values_are_json_and_rebuild_the_same_tile():
    values = draw_texture(np.random.default_rng(3), RED, TEXTURE_FAMILIES, (0.05, 0.2))
    assert json.loads(json.dumps(values)) == values
    assert values["palette"][0] == RED[:3] and 2 <= len(values["palette"]) <= 4
    assert 0.05 <= values["scale_m"] <= 0.2 and 0 <= values["rotation_deg"] < 360
    tile = texture_tile(values)
    assert tile.shape == (128, 128, 3) and tile.dtype == np.uint8
    assert np.array_equal(tile, texture_tile(json.loads(json.dumps(values))))


def test_palette_maps_the_field_ends_to_its_first_and_last_colours():
    image = apply_palette(np.array([[0.0, 1.0]]), [[1, 0, 0], [0, 0, 1]])
    assert image.tolist() == [[[255, 0, 0], [0, 0, 255]]]


def test_texture_coordinates_repeat_once_per_scale_in_metres():
    values = {"scale_m": 0.2, "rotation_deg": 90.0}
    uv = surface_uv(np.array([[0.0, 0.0], [0.2, 0.0]]), values)
    np.testing.assert_allclose(uv[1] - uv[0], [0.0, 1.0], atol=1e-6)
    picture = {"scale_m": 1.0, "rotation_deg": 0.0, "aspect": 2.0}  # twice as tall as wide
    np.testing.assert_allclose(surface_uv(np.array([[1.0, 2.0]]), picture), [[1.0, 1.0]])


def test_box_mapping_gives_each_face_a_planar_map_in_metres_and_flat_normals():
    box = trimesh.creation.box(extents=[0.4, 0.2, 0.1])
    mapped = box_mapped(box)
    assert mapped.vertices.shape == (36, 3) and mapped.uv_m.shape == (36, 2)
    for face in range(12):
        corners = slice(3 * face, 3 * face + 3)
        normal = box.face_normals[face]
        np.testing.assert_allclose(mapped.normals[corners], [normal] * 3, atol=1e-6)
        spans = np.ptp(mapped.uv_m[corners], axis=0)  # metres: within the face's two sides
        sides = sorted(np.delete(box.extents, np.argmax(np.abs(normal))))
        assert sorted(spans) == pytest.approx(sides)


def test_box_mapping_keeps_a_sphere_smooth():
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    mapped = box_mapped(sphere)
    smooth = np.asarray(sphere.vertex_normals)[sphere.faces].reshape(-1, 3)
    np.testing.assert_allclose(mapped.normals, smooth, atol=1e-6)


def _picture(path, image):
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), image)


def test_picture_folder_keeps_usable_pictures_and_skips_the_rest_with_reasons(tmp_path):
    rng = np.random.default_rng(0)
    colour = rng.integers(0, 256, (40, 60, 3), dtype=np.uint8)
    _picture(tmp_path / "wood.png", colour)
    _picture(tmp_path / "sub" / "photo.jpg", colour)
    _picture(tmp_path / "grey.png", colour[..., 0])
    _picture(tmp_path / "alpha.png", np.dstack([colour, colour[..., :1]]))
    _picture(tmp_path / "deep.png", colour.astype(np.uint16) * 257)
    _picture(tmp_path / "tiny.png", colour[:4, :4])
    _picture(tmp_path / "wide.png", np.zeros((8, 4100, 3), np.uint8))
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(100))
    (tmp_path / "notes.txt").write_text("not a picture")
    library = load_library(str(tmp_path))
    assert [p.path for p in library.pictures] == [
        "alpha.png", "deep.png", "grey.png", "sub/photo.jpg", "wood.png"
    ]  # fmt: skip
    reasons = dict(library.skipped)
    assert set(reasons) == {"broken.png", "notes.txt", "tiny.png", "wide.png"}
    assert "cannot decode" in reasons["broken.png"]
    assert "not a PNG or JPEG" in reasons["notes.txt"]
    assert "smaller than 8 px" in reasons["tiny.png"] and "4x4" in reasons["tiny.png"]
    assert "larger than 4096 px" in reasons["wide.png"]
    for picture in library.pictures:
        image = load_image(str(tmp_path), picture.path)
        assert image.shape == (40, 60, 3) and image.dtype == np.uint8
    assert np.array_equal(load_image(str(tmp_path), "wood.png"), colour[..., ::-1])  # RGB
    assert load_library(str(tmp_path)).report()["skipped"][0]["path"] == "broken.png"


def test_a_huge_picture_is_refused_from_its_header_before_decoding(tmp_path):
    _, encoded = cv2.imencode(".jpg", np.zeros((16, 16, 3), np.uint8))
    data = bytearray(encoded.tobytes())
    frame = data.index(b"\xff\xc0")  # baseline frame header: length, precision, height, width
    data[frame + 5 : frame + 9] = (30000).to_bytes(2, "big") * 2
    (tmp_path / "huge.jpg").write_bytes(bytes(data))
    with pytest.raises(ValueError, match="30000x30000 px, larger than 4096 px: downscale it"):
        check_picture(tmp_path / "huge.jpg")


def test_a_picture_changed_since_the_build_is_refused_not_drawn(tmp_path):
    _picture(tmp_path / "a.png", np.full((16, 16, 3), 9, np.uint8))
    values = {"family": "image", "root": str(tmp_path), "path": "a.png", "sha256": "0" * 64}
    with pytest.raises(ValueError, match=r"a\.png: not the picture the sample was made with"):
        texture_tile(values)


def test_big_pictures_are_drawn_downscaled(tmp_path):
    _picture(tmp_path / "big.png", np.full((1200, 2000, 3), 90, np.uint8))
    assert load_image(str(tmp_path), "big.png").shape == (307, 512, 3)


def test_a_folder_without_a_usable_picture_is_refused_naming_what_it_found(tmp_path):
    with pytest.raises(ImageFolderError, match="the folder is empty"):
        load_library(str(tmp_path))
    (tmp_path / "readme.md").write_text("textures go here")
    with pytest.raises(ImageFolderError, match=r"readme.md: not a PNG or JPEG file \(.md\)"):
        load_library(str(tmp_path / "."))  # another path: not the cached scan


def test_a_folder_of_too_many_files_is_refused_before_reading_them(tmp_path, monkeypatch):
    import datagen.assets.image_library

    monkeypatch.setattr(datagen.assets.image_library, "MAX_FILES", 5)
    for k in range(6):
        (tmp_path / f"{k}.txt").write_text("")
    with pytest.raises(ImageFolderError, match="more than 5 files; name a folder of pictures"):
        load_library(str(tmp_path))


def test_texture_config_keys_are_checked_by_name(tmp_path):
    with pytest.raises(ConfigError, match=r"materials.texture_families: expected a non-empty list from \['noise'"):  # fmt: skip
        config_from_dict({"materials": {"texture_families": ["plaid"]}})
    with pytest.raises(ConfigError, match=r"materials.textures_dir: expected a folder of PNG/JPEG"):  # fmt: skip
        config_from_dict({"materials": {"textures_dir": str(tmp_path / "missing")}})
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match=r"background.images_dir: .*no usable PNG or JPEG"):
        config_from_dict({"background": {"images_dir": str(tmp_path / "empty")}})


# the procedural textures alone: no photographs over them, no class-free recolouring
PROCEDURAL_ONLY = {
    "photos": {"enabled": False},
    "materials": {"class_independent_probability": 0.0},
}


def _scene(overrides, seed=5, index=2):
    merged = {**PROCEDURAL_ONLY, **overrides}
    merged["materials"] = {**PROCEDURAL_ONLY["materials"], **overrides.get("materials", {})}
    config = config_from_dict(merged)
    return draw_scene(config, seed, index, TRAY_CENTRE, TRAY_INNER_HALF)


def test_textures_come_from_their_own_stream_and_probability_0_gives_flat_colours():
    flat = _scene({"materials": {"texture_probability": 0.0}, "background": {"enabled": False}})
    textured = _scene({"materials": {"texture_probability": 1.0}})
    flat_surfaces = [*flat["materials"]["objects"], flat["materials"]["table"]]
    assert not any(m.textured for m in flat_surfaces)
    assert "background" not in flat
    for surface in ("table", "tray", "floor"):
        assert textured["materials"][surface].textured
        without = replace(textured["materials"][surface], texture=None)
        assert without == flat["materials"][surface]  # the colours are drawn as before
    for name in ("objects", "drop_poses", "lighting", "camera", "robot"):
        assert textured[name] == flat[name]
    assert json.loads(json.dumps(as_json(textured))) == as_json(textured)
    assert _scene({"materials": {"texture_probability": 1.0}}) == textured


def test_pictures_of_a_folder_are_drawn_with_their_digest(tmp_path):
    _picture(tmp_path / "tex" / "bricks.png", np.full((32, 64, 3), 120, np.uint8))
    params = _scene(
        {"materials": {"textures_dir": str(tmp_path / "tex"), "texture_probability": 1.0,
                       "textures_dir_share": 1.0}}
    )  # fmt: skip
    texture = params["materials"]["table"].texture
    assert texture["family"] == "image" and texture["path"] == "bricks.png"
    assert texture["aspect"] == 0.5 and len(texture["sha256"]) == 64
    side = texture["crop"][2]  # cropped as a photograph is (test_user_pictures.py)
    height, width, _ = texture_tile(texture).shape
    assert abs(height - side * 32) <= 1 and abs(width - side * 64) <= 1


def _config_file(tmp_path, **materials):
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump({"num_samples": 2, "materials": materials}))
    return path


@pytest.mark.parametrize("case", ["empty", "corrupt", "not_images", "tiny", "missing"])
def test_a_bad_texture_folder_ends_the_cli_with_one_line_and_exit_2(tmp_path, case):
    folder = tmp_path / "textures"
    if case != "missing":
        folder.mkdir()
    if case == "corrupt":
        (folder / "a.jpg").write_bytes(b"\xff\xd8\xff\xe0 not really a jpeg")
    elif case == "not_images":
        (folder / "a.exr").write_bytes(b"v/1\x01")
    elif case == "tiny":
        _picture(folder / "dot.png", np.zeros((3, 3, 3), np.uint8))
    config = _config_file(tmp_path, textures_dir="textures")
    result = subprocess.run(
        [str(Path(sys.executable).parent / "datagen"), "build", str(config), "--out", str(tmp_path / "out"), "--check"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert "materials.textures_dir" in lines[0] and str(config) in lines[0]
    expected = {
        "empty": "the folder is empty",
        "corrupt": "a.jpg: unreadable",
        "not_images": "a.exr: not a PNG or JPEG",
        "tiny": "dot.png: 3x3 px, smaller than 8 px",
        "missing": "expected a folder of PNG/JPEG pictures",
    }[case]
    assert expected in lines[0]


def test_a_relative_texture_folder_is_found_beside_the_config(tmp_path):
    _picture(tmp_path / "textures" / "ok.png", np.full((16, 16, 3), 7, np.uint8))
    config = config_from_dict(
        yaml.safe_load(_config_file(tmp_path, textures_dir="textures").read_text()),
        source=str(tmp_path / "config.yaml"),
    )
    assert config.materials.textures_dir == str((tmp_path / "textures").resolve())


def test_sample_streams_do_not_depend_on_texture_draws():
    # the texture stream is new: the materials stream draws exactly what it drew before
    rng = sample_rng(5, 2, "materials")
    from datagen.randomisers.materials import draw_materials

    config = config_from_dict({})
    params = _scene({})
    before = draw_materials(rng, config.materials, len(params["objects"]))
    assert [m.base_color for m in before["objects"]] == [
        m.base_color for m in params["materials"]["objects"]
    ]


def test_navigation_floors_walls_and_doors_are_textured_from_their_own_stream():
    from datagen.families.navigation.episode import plan_episode
    from datagen.families.navigation.values import TEXTURED_SURFACES, draw_nav_scene

    def values(probability):
        config = config_from_dict(
            {"scene": "navigation", "materials": {"texture_probability": probability}}
        )
        episode = plan_episode(config.navigation, 3, 1)
        return draw_nav_scene(config, 3, 1, episode.layout)

    flat, textured = values(0.0), values(1.0)
    for name in TEXTURED_SURFACES:
        assert not flat["materials"][name].textured
        assert replace(textured["materials"][name], texture=None) == flat["materials"][name]
        assert texture_tile(textured["materials"][name].texture).shape == (128, 128, 3)
    assert textured["materials"]["obstacles"] == flat["materials"]["obstacles"]
    assert {k: v for k, v in textured.items() if k != "materials"} == {k: v for k, v in flat.items() if k != "materials"}  # fmt: skip
