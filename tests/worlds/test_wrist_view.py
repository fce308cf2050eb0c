"""The wrist camera of the default build (issue 39 item 5): ``robot.pose: look`` puts it over
the tray looking down, where the randomiser drew it, for every built-in arm; and in every
default sample some view shows the targets at COCO's "medium" size or larger, checked on the
stored instance masks alone (no detector, no metadata)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from datagen.config import load_config
from datagen.config.robot import robot_spec, robot_workspace
from datagen.families.grasp_tabletop.produce import produce
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.families.grasp_tabletop.world import build_scene, construct_scene, take_look_pose
from datagen.geometry import look_at
from datagen.registries import ROBOTS

DEFAULT = Path(__file__).resolve().parents[2] / "configs" / "grasp_tabletop.yaml"
COCO_MEDIUM = 32 * 32  # px: COCO's area of a "medium" object
SAMPLES = 12


@pytest.mark.sim
@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_the_wrist_camera_sits_where_the_randomiser_drew_it(robot):
    config = load_config(DEFAULT)
    config = config.replace(robot=replace(config.robot, name=robot))
    config = config.replace(render=replace(config.render, width=64, height=48))
    ws = robot_workspace(config.robot)
    for index in range(3):
        params = draw_scene(config, 0, index, ws.tray_floor_top, ws.tray_inner_half)
        look = params["robot"].look
        scene = construct_scene(config, params)
        take_look_pose(scene)  # unsettled: objects may still be where the arm goes
        scene.scene.update_render()  # a camera on a link follows it when the render is updated
        pose = np.asarray(scene.cameras["wrist"].get_global_pose().to_transformation_matrix())
        drawn = look_at(look.eye, look.target, look.up)
        where = f"{robot} sample {index}"
        assert np.linalg.norm(pose[:3, 3] - drawn[:3, 3]) < 1e-3, where  # metres
        cosines = np.clip(np.einsum("ij,ij->j", pose[:3, :3], drawn[:3, :3]), -1, 1)
        assert np.degrees(np.arccos(cosines)).max() < 0.1, where
        above = look.eye[2] - ws.tray_floor_top[2]
        low, high = np.multiply(config.robot.look.height, robot_spec(config.robot).look_scale)
        assert low - 1e-6 <= above <= high + 1e-6, where
        qpos = scene.robot.get_qpos()
        limits = np.concatenate([j.get_limits() for j in scene.robot.get_active_joints()])
        assert ((limits[:, 0] - 1e-4 <= qpos) & (qpos <= limits[:, 1] + 1e-4)).all(), where


def _mask_areas(parts: dict[str, bytes], prefix: str, ids: list[int]) -> list[int]:
    seg = cv2.imdecode(np.frombuffer(parts[f"{prefix}seg.png"], np.uint8), cv2.IMREAD_UNCHANGED)
    return [int((seg == i).sum()) for i in ids]


@pytest.mark.sim
@pytest.mark.slow
def test_every_default_sample_has_a_view_with_medium_sized_targets():
    """Per sample: the targets a view annotates (mask area > 0) have a median area of at least
    32x32 px, and that view annotates at least half of the sample's targets."""
    config = load_config(DEFAULT)
    assert config.render.wrist_camera and config.robot.pose == "look"
    for index in range(SAMPLES):
        parts = produce(config, config.seed, index).parts
        targets = [o["instance_id"] for o in json.loads(parts["json"])["objects"]]
        best = {}
        for view, prefix in (("workspace", ""), ("wrist", "wrist.")):
            seen = [a for a in _mask_areas(parts, prefix, targets) if a > 0]
            if 2 * len(seen) >= len(targets):
                best[view] = float(np.median(seen))
        assert max(best.values(), default=0.0) >= COCO_MEDIUM, f"sample {index}: {best}"
        assert best.get("wrist", 0.0) >= COCO_MEDIUM, f"sample {index}: {best}"  # the one that does


@pytest.mark.sim
def test_an_object_where_the_posed_arm_reaches_is_reported():
    config = load_config(DEFAULT)
    config = config.replace(render=replace(config.render, width=64, height=48))
    scene = build_scene(config, 0, 0)
    assert take_look_pose(scene) == []  # the built scene: settled, posed, clear
    hand = next(link for link in scene.robot.get_links() if link.name == "panda_hand")
    scene.objects[0].entity.set_pose(hand.entity_pose)
    assert take_look_pose(scene) == [
        f"object 1 ({scene.objects[0].class_name}) meets the arm at its look pose"
    ]
