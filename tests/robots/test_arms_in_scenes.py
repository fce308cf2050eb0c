"""Every built-in arm in a real scene: it builds, the workspace camera sees it in every view, and
a short antipodal campaign succeeds at least once (real SAPIEN, physics and mplib planning)."""

from __future__ import annotations

import dataclasses
import json

import cv2
import numpy as np
import pytest

from datagen.config import load_config
from datagen.config.sections import RenderConfig
from datagen.registries import FAMILIES, ROBOTS

pytestmark = [pytest.mark.sim, pytest.mark.slow]
ARMS = sorted(ROBOTS)
# attempts tried before one must hold: four in five of a five-joint arm's find no candidate
# or no plan (issue 24); the jaw arms hold within these with their GripperSpec drive/friction
ATTEMPTS = 8


def with_robot(config_file: str, name: str, **render):
    config = load_config(config_file)
    robot = dataclasses.replace(config.robot, name=name)
    return config.replace(robot=robot, render=RenderConfig(width=160, height=120, **render))


def semantic(sample, prefix: str = "") -> np.ndarray:
    data = np.frombuffer(sample.parts[f"{prefix}semantic.png"], np.uint8)
    return cv2.imdecode(data, cv2.IMREAD_UNCHANGED)


@pytest.mark.parametrize("name", ARMS)
def test_the_arm_is_in_every_view(name):
    config = with_robot("configs/grasp_tabletop.yaml", name, views=3)
    for index in range(2):
        sample = FAMILIES["grasp_tabletop"].produce_sample(config, config.seed, index)
        meta = json.loads(sample.parts["json"])
        assert meta["robot"]["name"] == name
        joints = len(ROBOTS[name].load().joint_names)  # 7 + 2 fingers, or 5 + a jaw
        assert len(meta["robot"]["qpos"]) == len(meta["robot"]["joint_names"]) == joints
        robot = [meta["classes"].index(c) for c in ("robot", "gripper") if c in meta["classes"]]
        for view in meta["views"]:
            prefix = "" if view == "workspace" else f"{view}."
            pixels = int(np.isin(semantic(sample, prefix), robot).sum())
            assert pixels > 0, f"{name}: no robot pixels in {view} of sample {index}"


@pytest.mark.parametrize("name", ARMS)
def test_a_short_antipodal_campaign_succeeds(name):
    config = with_robot("configs/grasp_campaign.yaml", name)
    config = config.replace(campaign=dataclasses.replace(config.campaign, post_grasp_frame=False))
    outcomes = []
    for index in range(ATTEMPTS):
        sample = FAMILIES["grasp_attempts"].produce_sample(config, config.seed, index)
        outcome = json.loads(sample.parts["json"])["attempt"]["outcome"]
        outcomes.append((outcome["success"], outcome["failure_mode"]))
        if outcome["success"]:
            break
    assert any(success for success, _ in outcomes), f"{name}: {outcomes}"
