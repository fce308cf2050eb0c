"""The LeRobot export in the terms of lerobot's own arms (``datagen export DIR --to lerobot
--lerobot-robot NAME``): a grasp episode of datagen's so100 or koch written with the motor names,
order and units that lerobot 0.4.4's ``so100_follower`` or ``koch_follower`` records, so that
simulated episodes sit beside real ones (docs/export-lerobot.md).

lerobot reads a motor's position in one of its normalisation modes (``lerobot/motors/
motors_bus.py``, ``MotorNormMode``): ``degrees`` ((raw - mid) * 360 / 4095, mid the middle of the
calibrated range; the so100's body joints by default, ``use_degrees=True``), ``range_m100_100``
(-100 at the calibrated minimum, 100 at the maximum; the koch's default), and for the gripper
always ``range_0_100`` (0 at its minimum, 100 at its maximum). The calibration assumed: each
motor's calibrated range is its joint's limits in datagen's URDF (ManiSkill's), turning the way
the URDF's joint turns (drive mode 0), at 4096 steps a turn (Feetech STS3215, Dynamixel XL330 and
XL430 alike). A joint at q rad with limits [lo, hi] then reads:

- degrees: (q - (lo + hi) / 2) * 180 / pi * 4096 / 4095
- range_m100_100: 200 * (q - lo) / (hi - lo) - 100
- range_0_100: 100 * (q - lo) / (hi - lo)

The action's gripper is datagen's ``finger_target``, the jaw joint's drive target (rad).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from datagen.dataset.manifest import DatasetError
from datagen.exports.episodes import Episode

STEPS_PER_TURN = 4096  # lerobot's model resolution of the STS3215, XL330 and XL430
MID_STEP = STEPS_PER_TURN // 2 - 1  # where lerobot's half-turn homing puts a motor: 2047
UNITS = ("degrees", "range_m100_100")  # lerobot's body-joint modes (use_degrees True / False)
GRIPPER_UNITS = "range_0_100"
FINGER_ACTION = "finger_target"  # datagen's action column of the jaw joint's target


@dataclass(frozen=True)
class LeRobotArm:
    name: str  # lerobot's robot config type, the --lerobot-robot value
    robot_type: str  # what lerobot 0.4.4 records as robot_type: its Robot class's name
    datagen_robot: str  # the datagen robot it maps
    motors: tuple[tuple[str, str, float, float], ...]  # (motor, joint, lower, upper rad), by id
    units: str  # lerobot's default mode of the body joints

    def mode(self, motor: str, units: str) -> str:
        return GRIPPER_UNITS if motor == "gripper" else units


# joint limits: datagen's composed URDFs (robot_specs/so100.py, koch.py; ManiSkill's)
ARMS = {
    "so100_follower": LeRobotArm(
        "so100_follower",
        "so_follower",
        "so100",
        (
            ("shoulder_pan", "shoulder_pan", -2.0, 2.0),
            ("shoulder_lift", "shoulder_lift", -1.5708, 1.5708),
            ("elbow_flex", "elbow_flex", -1.5708, 1.5708),
            ("wrist_flex", "wrist_flex", -1.8, 1.8),
            ("wrist_roll", "wrist_roll", -3.14159, 3.14159),
            ("gripper", "gripper", -1.1, 1.1),
        ),
        "degrees",
    ),
    "koch_follower": LeRobotArm(
        "koch_follower",
        "koch_follower",
        "koch",
        (
            ("shoulder_pan", "joint_1", -3.14159, 3.14159),
            ("shoulder_lift", "joint_2", 0.0, 2.2),
            ("elbow_flex", "joint_3", 0.0, 3.05),
            ("wrist_flex", "joint_4", -1.5, 2.14159),
            ("wrist_roll", "joint_5", -3.14159, 3.14159),
            ("gripper", "joint_6", 0.0, 1.6),
        ),
        "range_m100_100",
    ),
}


def normalised(radians: np.ndarray, lower: float, upper: float, mode: str) -> np.ndarray:
    """What lerobot reads, in ``mode``, of a joint at ``radians`` under the assumed calibration."""
    if mode == "degrees":
        return np.degrees(radians - (lower + upper) / 2) * STEPS_PER_TURN / (STEPS_PER_TURN - 1)
    fraction = (np.clip(radians, lower, upper) - lower) / (upper - lower)  # lerobot clamps too
    return 200 * fraction - 100 if mode == "range_m100_100" else 100 * fraction


def calibration(arm: LeRobotArm, units: str) -> dict[str, Any]:
    """The assumed calibration, as lerobot's calibration file states it per motor (``id``,
    ``drive_mode``, ``homing_offset``, ``range_min``, ``range_max`` in steps, here not rounded),
    with the joint, its limits and the mode written."""
    out = {}
    for k, (motor, joint, lower, upper) in enumerate(arm.motors):
        half = (upper - lower) / 2 * STEPS_PER_TURN / (2 * math.pi)  # steps from the middle
        out[motor] = {
            "id": k + 1,
            "drive_mode": 0,
            "homing_offset": 0,
            "range_min": MID_STEP - half,
            "range_max": MID_STEP + half,
            "joint": joint,
            "lower_rad": lower,
            "upper_rad": upper,
            "mode": arm.mode(motor, units),
        }
    return out


def _columns(names: list[str], wanted: list[str], what: str, key: str) -> list[int]:
    missing = [name for name in wanted if name not in names]
    if missing:
        raise DatasetError(
            f"sample {key}: its episode's {what} has no {', '.join(missing)} (it has "
            f"{', '.join(names)}); the lerobot robot mapping needs every motor's joint"
        )
    return [names.index(name) for name in wanted]


def in_lerobot_units(episode: Episode, arm: LeRobotArm, units: str) -> Episode:
    """``episode`` with lerobot's motor names (``<motor>.pos``), order and units for ``arm``."""
    joints = [joint for _, joint, _, _ in arm.motors]
    state = episode.state[:, _columns(episode.state_names, joints, "state", episode.key)]
    action_joints = [*joints[:-1], FINGER_ACTION]
    action = episode.action[:, _columns(episode.action_names, action_joints, "action", episode.key)]
    for values in (state, action):
        for k, (motor, _, lower, upper) in enumerate(arm.motors):
            radians = values[:, k].astype(np.float64)
            values[:, k] = normalised(radians, lower, upper, arm.mode(motor, units))
    names = [f"{motor}.pos" for motor, _, _, _ in arm.motors]
    return dataclasses.replace(
        episode, state=state, state_names=names, action=action, action_names=list(names)
    )


def lerobot_arm(name: str, robot: object, kind: str) -> LeRobotArm:
    """The arm ``name`` for a dataset of ``robot`` episodes of ``kind``; DatasetError in one line
    if it maps another robot or the episodes are not grasps."""
    arm = ARMS.get(name)
    if arm is None:
        raise DatasetError(f"unknown lerobot robot {name!r}; expected one of {sorted(ARMS)}")
    if kind != "grasp" or robot != arm.datagen_robot:
        what = f"{robot!r} grasp attempts" if kind == "grasp" else f"{kind} episodes"
        raise DatasetError(
            f"cannot export 'lerobot' as lerobot's {name}: it maps datagen's "
            f"{arm.datagen_robot} arm, and this dataset holds {what}"
        )
    return arm
