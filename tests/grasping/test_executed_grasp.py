"""What a campaign records of the grasp the hand executed (issue 39): the executed grasp frame at
closure is forward kinematics of the recorded joint state then (the URDF read by datagen's own
parser, not SAPIEN), beside the planned pose; and a jaw arm holds its joints at their command
while it lifts and holds (so100, koch: the squeezing jaw left the wrist 0.15 rad off)."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest

from datagen.config import load_config
from datagen.config.robot import robot_spec
from datagen.config.sections import RenderConfig
from datagen.dataset.trajectory import decode_trajectory
from datagen.families.grasp_attempts.produce import produce
from datagen.robot_specs.urdf import read_urdf

pytestmark = [pytest.mark.sim, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
CONFIGS = {
    "panda": "grasp_campaign.yaml",
    "so100": "campaign_so100.yaml",
    "koch": "campaign_koch.yaml",
}
INDICES = range(8)  # the first attempt of seed 0 that lifts its target is checked
HOLD_GAP = 0.01  # rad: command - achieved of every arm joint through lift and hold


@functools.cache
def _lifted(robot: str):
    """(config, metadata, trajectory) of the first attempt of ``INDICES`` that succeeds."""
    config = load_config(REPO / "configs" / CONFIGS[robot]).replace(
        scene="grasp_attempts", render=RenderConfig(width=96, height=72)
    )
    for index in INDICES:
        sample = produce(config, config.seed, index)
        meta = sample.metadata
        if meta["attempt"]["outcome"]["success"]:
            return config, meta, decode_trajectory(sample.parts["trajectory.npz"])
    pytest.fail(f"no attempt of {robot}, seed {config.seed}, indices {INDICES} succeeds")


@pytest.mark.parametrize("robot", sorted(CONFIGS))
def test_the_executed_grasp_is_forward_kinematics_of_the_joints_at_closure(robot):
    config, meta, _ = _lifted(robot)
    spec, grasp = robot_spec(config.robot), meta["attempt"]["grasp"]
    joints = dict(zip(spec.joint_names, grasp["executed_qpos"], strict=True))
    base = np.asarray(meta["robot"]["base_pose"]["matrix"])
    tcp = base @ read_urdf(spec.urdf_path()).link_poses(joints)[spec.gripper.tcp_link]
    executed = np.asarray(grasp["executed_pose_world"])
    np.testing.assert_allclose(executed @ np.asarray(grasp["tcp_in_grasp"]), tcp, atol=2e-5)
    offset = np.linalg.inv(np.asarray(grasp["pose_world"])) @ executed
    np.testing.assert_allclose(grasp["executed_offset"]["position"], offset[:3, 3], atol=1e-6)
    assert np.linalg.norm(offset[:3, 3]) < 0.02, (robot, grasp["executed_offset"])


@pytest.mark.parametrize("robot", ["so100", "koch"])
def test_a_jaw_arm_holds_its_command_through_lift_and_hold(robot):
    _, _, trajectory = _lifted(robot)
    names = trajectory["names"]
    phases = [names["phases"].index("lift"), names["phases"].index("hold")]
    rows = np.isin(trajectory["phase"], phases)
    arm = names["action_names"][:-1]
    achieved = trajectory["qpos"][rows][:, [names["joint_names"].index(j) for j in arm]]
    gap = np.abs(trajectory["action"][rows][:, : len(arm)] - achieved).max(axis=0)
    assert rows.any() and gap.max() < HOLD_GAP, (robot, dict(zip(arm, gap.round(4), strict=True)))
