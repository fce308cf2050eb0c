"""Flying distractors (datagen/randomisers/distractors.py, ``draw_flying``): anywhere in the
workspace camera's view at depths from in front of the tray to beyond it, clear of the table,
the tray's space and the room's walls, from their own stream; labelled ``distractor`` in a real
render, after the other distractors; a card shows a whole photograph of the library; and
``flying: [0, 0]`` leaves a scene as it was."""

from __future__ import annotations

import dataclasses
import hashlib
import json

import cv2
import numpy as np
import pytest
from transforms3d.quaternions import quat2mat

from datagen.assets.shapes import build_geometry
from datagen.assets.tabletop_layout import DEFAULT_WORKSPACE, TRAY_CENTRE, TRAY_INNER_HALF
from datagen.config import BuildConfig
from datagen.config.appearance import (
    BackgroundConfig,
    CameraEffectsConfig,
    DistractorsConfig,
    PhotosConfig,
)
from datagen.config.sections import CameraConfig, MaterialsConfig, ObjectsConfig, RenderConfig
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.randomisers.background import draw_background
from datagen.randomisers.camera import draw_camera
from datagen.randomisers.distractors import (
    CARD,
    FLYING,
    TRAY_HEADROOM,
    draw_distractors,
    draw_flying,
)
from datagen.scene_values.bundles import distractor_values
from datagen.scene_values.checks import as_json
from datagen.seeding import sample_rng

ONLY_FLYING = DistractorsConfig(on_table=(0, 0), in_air=(0, 0), background=(0, 0), flying=(5, 5))
NO_PHOTOS = PhotosConfig(enabled=False)
ASPECT = 4 / 3  # the default 640 x 480 view


def _centre(spec: dict) -> np.ndarray:
    """World centre of the distractor's drawn bounding box."""
    lo, hi = build_geometry(spec["shape"]).visual.bounds
    return quat2mat(spec["pose"]["quat_wxyz"]) @ ((lo + hi) / 2) + spec["pose"]["position"]


def test_flying_distractors_lie_in_view_at_depths_spanning_the_range():
    ws, (lo, hi) = DEFAULT_WORKSPACE, ONLY_FLYING.flying_depth
    fractions, families, tilted, placed = [], set(), 0, 0
    for seed in range(60):
        camera = draw_camera(np.random.default_rng(seed), CameraConfig())
        room = None  # half the scenes in a room, half without one
        if seed % 2:
            room = draw_background(
                np.random.default_rng(seed), BackgroundConfig(), MaterialsConfig(), TRAY_CENTRE
            )["room"]
        flying = draw_flying(
            np.random.default_rng(seed), ONLY_FLYING, MaterialsConfig(), NO_PHOTOS, camera, room,
            ws, ASPECT,
        )  # fmt: skip
        stored = json.loads(json.dumps(as_json(flying)))  # as a sample stores them
        assert distractor_values(stored, "distractors") == flying  # read back, materials typed
        placed += len(flying)
        eye, target = np.asarray(camera.eye), np.asarray(camera.target)
        distance = np.linalg.norm(target - eye)
        forward = (target - eye) / distance
        right = np.cross(forward, [0, 0, 1]) / np.linalg.norm(np.cross(forward, [0, 0, 1]))
        up, tan_half = np.cross(right, forward), np.tan(np.deg2rad(camera.fovy_deg) / 2)
        for spec in flying:
            assert spec["placement"] == FLYING
            centre = _centre(spec)
            ray = centre - eye
            depth = ray @ forward
            assert abs(ray @ right) <= ASPECT * tan_half * depth + 1e-6  # in the image
            assert abs(ray @ up) <= tan_half * depth + 1e-6
            fractions.append(depth / distance)
            extent = float(np.max(build_geometry(spec["shape"]).obb_extents))
            assert extent <= 1.05 * ONLY_FLYING.flying_size[1]
            assert depth - extent / 2 > RenderConfig().near
            x, y, z = centre
            assert z > extent / 2 - 1e-6  # above the floor
            if abs(x) < ws.table_half[0] and abs(y) < ws.table_half[1]:
                assert z > ws.table_top  # over the table, never in it
            in_x = abs(x - TRAY_CENTRE[0]) < TRAY_INNER_HALF[0]
            if in_x and abs(y - TRAY_CENTRE[1]) < TRAY_INNER_HALF[1]:
                assert z > TRAY_CENTRE[2] + TRAY_HEADROOM  # above the targets
            if room is not None:  # beyond the table, still inside the room
                assert room["x"][0] < x < room["x"][1] and room["y"][0] < y < room["y"][1]
                assert z < room["height"]
            families.add(spec["shape"]["family"])
            rotation = quat2mat(spec["pose"]["quat_wxyz"])
            tilted += abs(rotation[2, 2]) < 0.9  # not just turned about the vertical
    assert placed >= 0.9 * 60 * 5  # nearly every one finds a spot
    assert lo <= min(fractions) < lo + 0.05 and hi - 0.15 < max(fractions) <= hi
    assert np.mean(np.asarray(fractions) > 1.0) > 0.15  # beyond the tray, not just in front
    assert CARD in families and len(families) >= 8
    assert tilted > 0.5 * placed


def test_flying_off_leaves_the_scene_as_it_was_and_the_stream_is_their_own():
    on = BuildConfig(photos=NO_PHOTOS)
    off = dataclasses.replace(on, distractors=dataclasses.replace(on.distractors, flying=(0, 0)))
    disabled = dataclasses.replace(on, distractors=DistractorsConfig(enabled=False))
    for index in range(6):
        with_flying = draw_scene(on, 7, index, TRAY_CENTRE, TRAY_INNER_HALF)
        without = draw_scene(off, 7, index, TRAY_CENTRE, TRAY_INNER_HALF)
        flying = [d for d in with_flying["distractors"] if d["placement"] == FLYING]
        # after the others, and nothing else moves
        others = with_flying["distractors"][: len(with_flying["distractors"]) - len(flying)]
        assert all(d["placement"] != FLYING for d in others)
        assert {**with_flying, "distractors": others} == without
        rng = sample_rng(7, index, "distractors")
        room = without["background"]["room"]
        assert without["distractors"] == draw_distractors(
            rng, off.distractors, off.materials, without["camera"], room
        )  # exactly what the scene drew before flying distractors
        assert flying == draw_flying(
            sample_rng(7, index, "distractors.flying"), on.distractors, on.materials, None,
            with_flying["camera"], room, aspect=640 / 480,
        )  # fmt: skip
        no_distractors = draw_scene(disabled, 7, index, TRAY_CENTRE, TRAY_INNER_HALF)
        assert "distractors" not in no_distractors
        assert no_distractors == {k: v for k, v in without.items() if k != "distractors"}


# --- real scenes ---

TINY = BuildConfig(
    objects=ObjectsConfig(count=(3, 3)),
    render=RenderConfig(width=128, height=96),
    distractors=DistractorsConfig(on_table=(1, 1), in_air=(0, 0), background=(1, 1), flying=(5, 5)),
    camera_effects=CameraEffectsConfig(enabled=False),
    photos=NO_PHOTOS,
)


@pytest.mark.sim
def test_flying_distractors_are_rendered_and_labelled_after_the_others():
    from datagen.families.grasp_tabletop.produce import render_annotated

    annotated = render_annotated(TINY, 3, 0)
    meta, view = annotated.metadata, annotated.views["workspace"]
    specs = meta["randomisation"]["distractors"]
    placements = [spec["placement"] for spec in specs]
    assert placements.count(FLYING) >= 4 and placements[-placements.count(FLYING) :] == [
        FLYING
    ] * placements.count(FLYING)
    distractor_id = meta["classes"].index("distractor")
    records = [r for r in meta["views"]["workspace"]["objects"] if r["role"] == "distractor"]
    first = len(meta["objects"]) + 1  # instance ids: targets, then distractors in their order
    assert [r["instance_id"] for r in records] == list(range(first, first + len(specs)))
    flying = [r for r, p in zip(records, placements, strict=True) if p == FLYING]
    seen = [r for r in flying if r["visible"]]
    assert len(seen) >= 2
    for record in seen:
        mask = view.instance == record["instance_id"]
        assert mask.sum() == record["visible_pixels"] > 0
        assert record["class"] == "distractor" and (view.semantic[mask] == distractor_id).all()


def _photo_library(root) -> None:
    """A real one-source library: one 64 x 48 JPEG, left half red, right half blue."""
    picture = np.zeros((48, 64, 3), np.uint8)
    picture[:, :32, 2], picture[:, 32:, 0] = 255, 255  # BGR: red on the left, blue on the right
    data = cv2.imencode(".jpg", picture)[1].tobytes()
    (root / "mine").mkdir(parents=True)
    (root / "mine" / "halves.jpg").write_bytes(data)
    digest = hashlib.sha256(data).hexdigest()
    entry = {
        "path": "mine/halves.jpg",
        "source": "mine",
        "kind": "photo",
        "width": 64,
        "height": 48,
        "sha256": digest,
        "original_sha256": digest,
        "package": "mine==1.0",
        "member": "halves.jpg",
        "licence": "CC0-1.0",
        "copyright": "datagen's tests",
        "url": "",
    }
    source = {"package": "mine==1.0", "registry": "pip", "kind": "photo", "url": "", "files": 1}
    manifest = {"version": 1, "sources": {"mine": source}, "files": [entry]}
    (root / "manifest.json").write_text(json.dumps(manifest))


@pytest.mark.sim
def test_a_flying_card_shows_the_whole_photograph(tmp_path, monkeypatch):
    from datagen.families.grasp_tabletop.produce import render_annotated

    _photo_library(tmp_path)
    monkeypatch.setenv("DATAGEN_LIBRARY", str(tmp_path))
    photos = PhotosConfig(
        sources=("mine",), held_out=(), surface_probability=0.0, backdrop_probability=0.0,
        distractor_probability=1.0, crop=(1.0, 1.0), contrast=(1.0, 1.0),
        brightness=(0.0, 0.0), saturation=(1.0, 1.0), hue_deg=(0.0, 0.0),
    )  # fmt: skip
    config = dataclasses.replace(
        TINY,
        photos=photos,
        distractors=dataclasses.replace(ONLY_FLYING, flying_size=(0.2, 0.3)),
    )
    annotated = render_annotated(config, 3, 0)
    meta, view = annotated.metadata, annotated.views["workspace"]
    specs = meta["randomisation"]["distractors"]
    assert len(specs) == 5
    for spec in specs:  # every one a card showing the picture once, unrotated
        width, height, thickness = spec["shape"]["parts"][0]["extents"]
        texture = spec["material"]["texture"]
        assert spec["shape"]["family"] == CARD and thickness < 0.01
        assert texture["family"] == "photo" and texture["path"] == "mine/halves.jpg"
        assert texture["scale_m"] == width and texture["rotation_deg"] == 0.0
        assert height == pytest.approx(width * 0.75, abs=1e-5)
    records = [r for r in meta["views"]["workspace"]["objects"] if r["role"] == "distractor"]
    both = 0
    for record in records:
        pixels = view.rgb[view.instance == record["instance_id"]].astype(int)
        if len(pixels) >= 30:  # both halves of the picture on one card: red and blue pixels
            red, blue = pixels[:, 0] > pixels[:, 2] + 30, pixels[:, 2] > pixels[:, 0] + 30
            both += red.mean() > 0.1 and blue.mean() > 0.1
    assert both >= 1
