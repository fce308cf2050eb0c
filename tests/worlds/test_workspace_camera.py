"""The default workspace camera stands behind the robot (issue 24): every workspace view of a
default scene, extra views and jitter included, sees the arm, the gripper and the tray's inner
area; the arm and the gripper are labelled instances (classes ``robot`` and ``gripper``) with
per-view records. The camera defaults were chosen on 50 scenes x 3 views
(docs/grasp-tabletop.md)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from datagen.assets.tabletop_layout import TRAY_CENTRE, TRAY_FLOOR, TRAY_INNER_HALF, TRAY_WALL
from datagen.config import load_config
from datagen.dataset.views import labelled_views, thing_classes
from datagen.families.grasp_tabletop.world import CLASSES
from datagen.geometry import image_points

REPO_CONFIGS = Path(__file__).resolve().parents[2] / "configs"
SAMPLES = 5
VIEWS = 3


def _tray_points() -> tuple[np.ndarray, np.ndarray]:
    """(a 15 x 15 grid on the tray's inner floor, the 8 corners of the tray's outer box)."""
    (cx, cy, cz), (ix, iy) = TRAY_CENTRE, TRAY_INNER_HALF
    gx, gy = np.meshgrid(np.linspace(cx - ix, cx + ix, 15), np.linspace(cy - iy, cy + iy, 15))
    floor = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, cz + TRAY_FLOOR)], 1)
    ox, oy = ix + TRAY_WALL[0], iy + TRAY_WALL[0]
    corners = [
        [cx + sx * ox, cy + sy * oy, cz + z]
        for sx in (-1, 1)
        for sy in (-1, 1)
        for z in (0.0, TRAY_WALL[1])
    ]
    return floor, np.array(corners)


@pytest.fixture(scope="module")
def default_samples():
    from datagen.families.grasp_tabletop.produce import render_annotated

    cfg = load_config(REPO_CONFIGS / "grasp_tabletop.yaml")
    cfg = cfg.replace(render=replace(cfg.render, width=320, height=240, views=VIEWS))
    return [render_annotated(cfg, 7, index) for index in range(SAMPLES)]


def test_gripper_class_comes_last_so_earlier_ids_stay():
    assert CLASSES[4] == "robot" and CLASSES[-3:] == ("distractor", "wall", "gripper")


@pytest.mark.sim
@pytest.mark.slow
def test_every_default_view_sees_arm_gripper_and_tray(default_samples):
    floor, corners = _tray_points()
    for sample in default_samples:
        assert list(sample.views)[-1] == "wrist" and len(sample.views) == VIEWS + 1
        for name, view in list(sample.views.items())[:VIEWS]:  # the wrist camera: test_wrist_view
            meta = sample.metadata["views"][name]
            camera = meta["camera"]
            width, height = camera["width"], camera["height"]
            arm, gripper = meta["robot_parts"]
            where = f"sample {sample.index} {name}"
            assert (arm["class"], gripper["class"]) == ("robot", "gripper"), where
            assert arm["visible_pixels"] > 0 and gripper["visible_pixels"] > 0, where
            assert arm["in_frame_fraction"] > 0.9, where
            semantic = sample.metadata["classes"]
            for part in (arm, gripper):
                mask = view.instance == part["instance_id"]
                assert int(mask.sum()) == part["visible_pixels"], where
                assert semantic[int(np.unique(view.semantic[mask])[0])] == part["class"], where
                assert len(np.unique(view.semantic[mask])) == 1, where
                x0, y0, x1, y1 = part["bbox_xyxy"]
                rows, cols = np.nonzero(mask)
                assert [x0, y0, x1, y1] == [cols.min(), rows.min(), cols.max(), rows.max()]
                assert 0 < part["visible_fraction"] <= part["in_frame_fraction"] + 1e-6, where
            # instance ids: objects and distractors first, then the arm and the gripper
            assert gripper["instance_id"] == arm["instance_id"] + 1 == len(meta["objects"]) + 2
            # the pinhole render's camera: projecting world points needs no lens
            k = np.asarray(camera.get("render_intrinsics", camera["intrinsics"]), float)
            e = np.asarray(camera["extrinsics_world_to_camera"], float)
            uv, _ = image_points(corners, k, e)
            assert ((uv >= 0) & (uv < [width, height])).all(), f"{where}: tray not all in frame"
            uv, _ = image_points(floor, k, e)
            px = np.clip(uv.astype(int), 0, [width - 1, height - 1])
            robot_ids = [arm["instance_id"], gripper["instance_id"]]
            hidden = np.isin(view.instance[px[:, 1], px[:, 0]], robot_ids)
            if "distortion" not in camera:  # a lens moves pixels: the in-frame test above holds
                assert hidden.mean() < 0.2, f"{where}: the arm hides the tray"


@pytest.mark.sim
@pytest.mark.slow
def test_robot_parts_are_coco_instances(default_samples):
    meta = default_samples[0].metadata
    classes = thing_classes(meta["classes"])
    assert {"robot", "gripper"} <= set(classes)
    for view in labelled_views(meta):  # the wrist camera sees its gripper, not the arm
        expected = {"gripper"} if view.name == "wrist" else {"robot", "gripper"}
        assert expected <= {i["class"] for i in view.instances}


@pytest.mark.sim
def test_closeup_config_keeps_the_old_camera():
    from datagen.families.grasp_tabletop.produce import render_annotated

    cfg = load_config(REPO_CONFIGS / "grasp_closeup.yaml")
    assert cfg.camera.eye == (-0.22, 0.28, 1.22) and cfg.camera.target == (0.08, 0.0, 0.76)
    cfg = cfg.replace(render=replace(cfg.render, width=160, height=120))
    meta = render_annotated(cfg, 7, 0).metadata["views"]["workspace"]
    assert [p["class"] for p in meta["robot_parts"]] == ["robot", "gripper"]
