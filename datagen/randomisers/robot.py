"""Robot randomiser: the Panda's initial joint configuration around a ready pose."""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.config.sections import RobotConfig
from datagen.robot_specs.panda import PANDA


def sample_robot(rng: np.random.Generator, cfg: RobotConfig) -> dict[str, Any]:
    """Joint positions: the arm's ready pose jittered, both fingers opened alike (radians,
    metres)."""
    ready = PANDA.ready_pose
    arm = np.asarray(ready) + rng.uniform(-cfg.joint_jitter, cfg.joint_jitter, len(ready))
    finger = float(rng.uniform(*PANDA.gripper.finger_travel))
    return {"qpos": np.round(np.append(arm, [finger, finger]), 6).tolist()}
