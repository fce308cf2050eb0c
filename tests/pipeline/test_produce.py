"""One sample rendered in-process on the real renderer: cameras, calibration and parts."""

from __future__ import annotations

import json

import numpy as np
import pytest

from datagen.config import BuildConfig
from datagen.config.sections import RenderConfig
from datagen.families.grasp_tabletop.produce import render_annotated, to_sample
from datagen.families.grasp_tabletop.world import build_scene
from datagen.sensing.render import capture

pytestmark = pytest.mark.sim

CONFIG = BuildConfig(render=RenderConfig(width=160, height=120, wrist_camera=True))


@pytest.fixture(scope="module")
def annotated():
    return render_annotated(CONFIG, 3, 11)


def test_wrist_camera_gives_its_own_parts_and_view(annotated):
    sample = to_sample(annotated)
    for prefix in ("", "wrist."):
        for name in ("rgb.png", "depth.png", "seg.png", "semantic.png"):
            assert sample.parts[prefix + name][:8] == b"\x89PNG\r\n\x1a\n"
    meta = json.loads(sample.parts["json"])
    assert set(meta["views"]) == {"workspace", "wrist"}
    assert meta["views"]["wrist"]["camera"]["width"] == 160


def test_extrinsics_match_sapien_and_project_objects_into_their_boxes(annotated):
    scene = build_scene(CONFIG, 3, 11)
    scene.scene.update_render()
    for name, camera in scene.cameras.items():
        frame = capture(camera)
        sapien_extrinsics = np.asarray(camera.get_extrinsic_matrix())  # (3, 4), OpenCV convention
        assert np.allclose(frame.extrinsics[:3], sapien_extrinsics, atol=1e-5), name
    view = annotated.metadata["views"]["workspace"]
    K = np.asarray(view["camera"]["intrinsics"])
    for record in view["objects"]:
        if record["visible_fraction"] < 0.6 or record["visible_pixels"] < 30:
            continue
        centre = np.asarray(record["pose_camera"]["position"])
        u, v = (K @ centre)[:2] / centre[2] - 0.5
        x0, y0, x1, y1 = record["bbox_xyxy"]
        margin = 0.25 * max(x1 - x0, y1 - y0)  # object origin is near, not at, the mask centre
        assert x0 - margin <= u <= x1 + margin and y0 - margin <= v <= y1 + margin, record


def test_same_seed_and_index_render_identical_pixels(annotated):
    again = render_annotated(CONFIG, 3, 11)
    for name, view in annotated.views.items():
        assert np.array_equal(view.rgb, again.views[name].rgb)
        assert np.array_equal(view.depth, again.views[name].depth)
    assert json.dumps(annotated.metadata, sort_keys=True) == json.dumps(
        again.metadata, sort_keys=True
    )
