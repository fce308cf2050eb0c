"""Robot randomiser: the Panda's initial joint configuration around a ready pose."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien

from datagen.config.sections import RobotConfig

# Panda arm joints 1-7 (radians): arm raised and folded back so the tray stays in view.
READY_POSE = (0.0, -0.95, 0.0, -2.75, 0.0, 1.95, 0.785)
FINGER_OPENING = (0.0, 0.04)  # metres per finger


def sample_robot(rng: np.random.Generator, cfg: RobotConfig) -> dict[str, Any]:
    arm = np.asarray(READY_POSE) + rng.uniform(-cfg.joint_jitter, cfg.joint_jitter, len(READY_POSE))
    finger = float(rng.uniform(*FINGER_OPENING))
    return {"qpos": np.round(np.append(arm, [finger, finger]), 6).tolist()}


def apply_robot(robot: sapien.physx.PhysxArticulation, values: dict[str, Any]) -> None:
    """Sets the joints and holds them there with stiff PD drives (stiffness N·m/rad)."""
    qpos = np.asarray(values["qpos"], np.float32)
    joints = robot.get_active_joints()
    if len(joints) != len(qpos):
        raise ValueError(f"robot has {len(joints)} active joints, sampled qpos has {len(qpos)}")
    robot.set_qpos(qpos)
    for joint, target in zip(joints, qpos, strict=True):
        joint.set_drive_property(stiffness=2000.0, damping=200.0)
        joint.set_drive_target(float(target))
