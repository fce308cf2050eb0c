"""UFACTORY xArm7 with the Franka hand: the arm as ManiSkill ships it
(``robots/xarm7/xarm7.urdf``, no gripper), the hand from ManiSkill's panda_v2, composed into one
URDF on first use (:mod:`datagen.robot_specs.compose`)."""

from __future__ import annotations

from pathlib import Path

from datagen.robot_specs import RobotSpec
from datagen.robot_specs.compose import Composition, compose_srdf, compose_urdf
from datagen.robot_specs.panda import FRANKA_HAND, FRANKA_WRIST_CAMERA

COMPOSITION = Composition(
    name="xarm7",
    arm="mani_skill:robots/xarm7/xarm7.urdf",
    flange="link_eef",  # the tool flange, fixed to link7 at its origin
)


def urdf() -> Path:
    return compose_urdf(COMPOSITION)


def srdf() -> Path:
    return compose_srdf(COMPOSITION)


XARM7 = RobotSpec(
    name="xarm7",
    summary="UFACTORY xArm7 with the Franka hand (ManiSkill's xarm7)",
    description="composed:datagen.robot_specs.xarm7:urdf",
    srdf="composed:datagen.robot_specs.xarm7:srdf",
    licence="BSD-3-Clause (UFACTORY xarm_ros, as shipped by ManiSkill) + Apache-2.0 (Franka hand)",
    arm_joints=tuple(f"joint{i}" for i in range(1, 8)),
    # arm raised and folded back so the tray stays in view: TCP ~(0.30, 0, 0.41) m from the
    # base, pointing down; joint 4 limited to -0.19..3.93 rad
    ready_pose=(0.0, -0.6, 0.0, 0.95, 0.0, 1.55, 0.0),
    gripper=FRANKA_HAND,
    wrist_camera=FRANKA_WRIST_CAMERA,
    reach=0.70,  # datasheet, to the flange
    # 0.1 m nearer the tray than the Panda (its reach is 0.15 m shorter); link_base's collision
    # mesh ends at z = 0: 1 mm clear of the table
    mount=(0.1, 0.0, 0.001),
)
