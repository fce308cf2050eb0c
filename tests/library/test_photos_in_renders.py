"""The library's photographs on the real renderer: a wall's photograph is found in the
rendered image by feature matching (SIFT, a RANSAC homography), a picture that was not drawn
is not; held-out sources are never drawn."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from datagen.assets.tabletop_layout import TRAY_CENTRE, TRAY_INNER_HALF
from datagen.assets.texture_tiles import texture_tile
from datagen.config import config_from_dict
from datagen.families.grasp_tabletop.produce import annotate_scene
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.families.grasp_tabletop.world import CLASSES, build_scene
from datagen.library.catalogue import load_picture, pictures
from datagen.scene_values.checks import as_json
from datagen.sensing.render import keep_renderer_alive

LOOK_AT_THE_PHOTO = {  # from above the table towards the +x wall, 1.5 m away, photos on walls
    "render": {"width": 640, "height": 480},
    "objects": {"count": [1, 1]},
    "camera": {"eye": [0.0, 0.0, 1.4], "target": [1.0, 0.0, 1.4], "eye_jitter": 0.0,
               "target_jitter": 0.0, "fovy_deg": [40, 40]},
    "background": {"room_half_size": [1.5, 1.5], "wall_height": [2.6, 2.6], "room_lights": [0, 0]},
    "lighting": {"ambient": [0.5, 0.5], "lights": [1, 1]},
    "photos": {"sources": ["mate-backgrounds"], "backdrop_probability": 1.0,
               "backdrop_scale_m": [2.0, 2.0], "crop": [1.0, 1.0]},
    "distractors": {"enabled": False},
    "camera_effects": {"enabled": False},
}  # fmt: skip


def _inliers(picture: np.ndarray, image: np.ndarray) -> int:
    """Feature matches between two RGB images consistent with one homography (RANSAC)."""
    sift = cv2.SIFT_create()
    grey = [cv2.cvtColor(np.ascontiguousarray(x), cv2.COLOR_RGB2GRAY) for x in (picture, image)]
    (kp1, des1), (kp2, des2) = (sift.detectAndCompute(g, None) for g in grey)
    if des1 is None or des2 is None or len(kp1) < 4 or len(kp2) < 4:
        return 0
    pairs = cv2.BFMatcher().knnMatch(des1, des2, k=2)
    good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < 0.7 * p[1].distance]
    if len(good) < 4:
        return 0
    src = np.float32([kp1[m.queryIdx].pt for m in good])
    dst = np.float32([kp2[m.trainIdx].pt for m in good])
    _, mask = cv2.findHomography(src, dst, cv2.RANSAC, 4.0)
    return int(mask.sum()) if mask is not None else 0


@pytest.mark.sim
def test_a_library_photograph_on_a_wall_is_found_in_the_render():
    keep_renderer_alive()
    config = config_from_dict(LOOK_AT_THE_PHOTO)
    annotated = annotate_scene(build_scene(config, 3, 0), config, 3, 0, cameras=("workspace",))
    view = annotated.views["workspace"]
    assert (view.semantic == CLASSES.index("wall")).mean() > 0.9, "the camera faces the +x wall"
    texture = annotated.metadata["randomisation"]["background"]["walls"]["x_max"]["texture"]
    assert texture["family"] == "photo" and texture["source"] == "mate-backgrounds"
    drawn = _inliers(texture_tile(texture), view.rgb)
    others = [p for p in pictures(["skimage-data"])[:4]]
    not_drawn = max(_inliers(load_picture(p["path"], p["sha256"]), view.rgb) for p in others)
    assert drawn >= 25 and drawn > 4 * max(not_drawn, 1), (drawn, not_drawn)


def _photo_textures(value):
    value = as_json(value)  # the values as stored (materials typed in the draw)
    if isinstance(value, dict):
        if value.get("family") == "photo":
            yield value
        for item in value.values():
            yield from _photo_textures(item)
    elif isinstance(value, list):
        for item in value:
            yield from _photo_textures(item)


def test_held_out_sources_are_never_drawn_and_the_sources_all_are():
    config = config_from_dict({"photos": {"surface_probability": 0.5}})
    drawn = [
        texture
        for index in range(60)
        for texture in _photo_textures(draw_scene(config, 7, index, TRAY_CENTRE, TRAY_INNER_HALF))
    ]
    sources = {t["source"] for t in drawn}
    assert sources == set(config.photos.sources)
    assert not sources & set(config.photos.held_out)
    listed = {p["path"]: p for p in pictures(config.photos.sources)}
    assert all(listed[t["path"]]["sha256"] == t["sha256"] for t in drawn)
