"""Robot randomiser: the arm's initial joint configuration around its ready pose."""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.config.robot import RobotConfig, robot_spec


def sample_robot(rng: np.random.Generator, cfg: RobotConfig) -> dict[str, Any]:
    """Joint positions: the arm's ready pose jittered, the finger joints (two prismatic fingers,
    or one jaw) opened alike within their travel (radians, metres), in the order of the record's
    ``joint_names``."""
    spec = robot_spec(cfg)
    ready = spec.ready_pose
    arm = np.asarray(ready) + rng.uniform(-cfg.joint_jitter, cfg.joint_jitter, len(ready))
    finger = float(rng.uniform(*spec.gripper.finger_travel))
    fingers = [finger] * len(spec.gripper.finger_joints)
    return {"qpos": np.round(np.append(arm, fingers), 6).tolist()}
