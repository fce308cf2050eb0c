"""``campaign.check_reach`` in real scenes (SAPIEN and mplib, in process): a candidate the
planner reaches is executed in place of one whose pre-grasp pose has no IK solution, the
attempt records how many candidates were checked, it stays a function of (seed, index), and a
candidate the arm cannot lift is not reached."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from datagen.config import config_from_dict
from datagen.families.grasp_attempts.gripper_geometry import gripper_geometry
from datagen.families.grasp_attempts.produce import (
    attempt_scene,
    execution_params,
    grasp_problem,
    observe_attempt,
    produce,
)
from datagen.families.grasp_attempts.reach import ArmReach
from datagen.families.grasp_attempts.samplers.antipodal import AntipodalSampler

pytestmark = [pytest.mark.sim]

REPO = Path(__file__).resolve().parents[2]
SEED = 1000
LOOKED_AT = 16  # attempt indices searched for IK failures of the plain antipodal sampler


def config(check_reach: bool):
    data = yaml.safe_load((REPO / "configs/grasp_campaign.yaml").read_text())
    data["campaign"] |= {"post_grasp_frame": False, "record_hz": 0, "check_reach": check_reach}
    data["render"] = {"width": 160, "height": 120, "wrist_camera": True}
    return config_from_dict(data)


def attempt(sample) -> dict:
    return json.loads(sample.parts["json"])["attempt"]


def transit(record: dict) -> str | None:
    return (record["outcome"]["details"].get("transit") or {}).get("status")


def test_a_reached_candidate_replaces_one_the_arm_cannot_reach():
    plain, checked = config(False), config(True)
    failed = []  # attempts whose antipodal grasp had no IK solution at its pre-grasp pose
    for index in range(LOOKED_AT):
        if transit(attempt(produce(plain, SEED, index))) == "IK failed":
            failed.append(index)
        if len(failed) == 3:
            break
    assert failed, f"no IK failure in the first {LOOKED_AT} attempts: pick another seed"
    mended = 0
    for index in failed:
        record = attempt(produce(checked, SEED, index))
        info = record["grasp"]["info"]
        assert info["reach_checked"] >= 1 and isinstance(info["reached"], bool)
        if info["reached"]:
            assert info["reach_checked"] >= 2  # the first candidate was the one that failed
            assert transit(record) == "Success"
            mended += 1
    assert mended >= 1


def test_an_attempt_with_reach_checked_is_reproduced_from_seed_and_index():
    checked = config(True)
    first, again = produce(checked, SEED, 0), produce(checked, SEED, 0)
    assert first.parts.keys() == again.parts.keys()
    for name in first.parts:
        assert first.parts[name] == again.parts[name], name


def test_a_candidate_is_reached_only_when_the_arm_can_also_lift_it():
    """The check plans the lift too: the candidates it passes with the campaign's lift of 0.1 m
    all fail it with a lift of 1.5 m, beyond any arm's reach."""
    checked = config(True)
    scene = attempt_scene(checked, SEED, 0)
    campaign, _, target = observe_attempt(checked, SEED, 0, 0, scene)
    sampler = AntipodalSampler.from_campaign(campaign, gripper_geometry(scene.spec))
    found, _, _ = sampler.draw(np.random.default_rng(0), *grasp_problem(scene, target), 8, 200, 4)
    params = execution_params(campaign)
    lifts = ArmReach(scene, params)
    too_high = ArmReach(scene, dataclasses.replace(params, lift_height=1.5))
    reached = [candidate for candidate in found if lifts(candidate)]
    assert reached, f"none of {len(found)} candidates reached: pick another index"
    assert not any(too_high(candidate) for candidate in reached)
