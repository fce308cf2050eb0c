"""KUKA LBR iiwa 14 R820 with the Franka hand: the arm vendored from pybullet
(``descriptions/iiwa14/``, inertials recomputed), the hand from ManiSkill's panda_v2, composed
into one URDF on first use (:mod:`datagen.robot_specs.compose`)."""

from __future__ import annotations

from pathlib import Path

from datagen.robot_specs import RobotSpec
from datagen.robot_specs.compose import Composition, compose_srdf, compose_urdf
from datagen.robot_specs.panda import FRANKA_HAND, FRANKA_WRIST_CAMERA

COMPOSITION = Composition(
    name="iiwa14",
    arm="datagen:iiwa14/iiwa14.urdf",
    flange="lbr_iiwa_link_7",
    mount_xyz=(0.0, 0.0, 0.045),  # the media flange: the top of link_7's mesh
)


def urdf() -> Path:
    return compose_urdf(COMPOSITION)


def srdf() -> Path:
    return compose_srdf(COMPOSITION)


IIWA14 = RobotSpec(
    name="iiwa14",
    summary="KUKA LBR iiwa 14 R820 with the Franka hand",
    description="composed:datagen.robot_specs.iiwa14:urdf",
    srdf="composed:datagen.robot_specs.iiwa14:srdf",
    licence="BSD-2-Clause (Krug & Stoyanov, Örebro 2015, via pybullet, zlib) + Apache-2.0 (Franka hand)",
    arm_joints=tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8)),
    # arm raised and folded back so the tray stays in view: TCP ~(0.33, 0, 0.42) m from the
    # base, pointing down; joints 2, 4, 6 limited to +-2.094 rad
    ready_pose=(0.0, -0.1, 0.0, -1.95, 0.0, 1.25, 0.0),
    gripper=FRANKA_HAND,
    wrist_camera=FRANKA_WRIST_CAMERA,
    reach=0.82,  # datasheet, to the flange
    # link_0's collision mesh reaches 3.4e-6 m below its frame: raised 1 mm so that the planner
    # does not see the base in collision with the table top it stands on
    mount=(0.0, 0.0, 0.001),
)
