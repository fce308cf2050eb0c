"""Koch v1.1 follower arm, as ManiSkill ships it (``robots/koch/follower_arm_v1.1.urdf`` and its
SRDF): five arm joints and a jaw gripper, the revolute ``joint_6`` swinging link ``gripper``
against the jaw of ``link_6``. Composed on first use with a TCP and two pad frames in datagen's
convention, its ``package://`` meshes relinked, turned to face +x
(:mod:`datagen.robot_specs.compose`)."""

from __future__ import annotations

import math
from pathlib import Path

from datagen.robot_specs import GripperSpec, RobotSpec, tcp_camera
from datagen.robot_specs.compose import Frame, FrameComposition, compose_framed_urdf

COMPOSITION = FrameComposition(
    name="koch",
    source="mani_skill:robots/koch/follower_arm_v1.1.urdf",
    frames=(
        # midway between the pads at half opening (joint_6 0.60 rad); z along the jaws (-z of
        # link_6), y from the fixed jaw to the moving one (+x of link_6)
        Frame("koch_tcp", "link_6", (0.00799, 0.0, -0.06356), (math.pi, 0.0, math.pi / 2)),
        # on the inner faces of the collision shapes, near the jaw tips
        Frame("koch_fixed_pad", "link_6", (-0.0089, 0.0, -0.064)),
        Frame("koch_moving_pad", "gripper", (-0.0135, 0.0174, -0.051)),
    ),
    base_yaw=math.pi / 2,  # ManiSkill's koch faces -y of its base_link
)


def urdf() -> Path:
    return compose_framed_urdf(COMPOSITION)


KOCH = RobotSpec(
    name="koch",
    summary="Koch v1.1 low-cost arm with its jaw gripper (ManiSkill's koch-v1.1)",
    description="composed:datagen.robot_specs.koch:urdf",
    srdf="mani_skill:robots/koch/follower_arm_v1.1.srdf",
    licence="Apache-2.0 (jess-moss/koch-v1-1, as shipped by ManiSkill)",
    arm_joints=tuple(f"joint_{i}" for i in range(1, 6)),
    # arm raised, jaws pointing down: TCP ~(0.13, 0, 0.11) m from the base
    ready_pose=(0.162, 1.88, 1.31, 2.141, -1.737),
    gripper=GripperSpec(
        hand_link="link_6",
        tcp_link="koch_tcp",
        finger_links=("gripper", "link_6"),
        finger_joints=("joint_6",),
        finger_travel=(0.0, 1.6),  # radians, closed .. open: 0.003 .. 0.068 m
        pad_links=("koch_moving_pad", "koch_fixed_pad"),
        drive=(100.0, 10.0, 1.0),  # N·m/rad, N·m·s/rad, N·m: 15-20 N between the jaw tips
        friction=2.0,  # as ManiSkill's so100 jaws: the default 0.3 lets a lifted object slip
    ),
    reach=0.34,  # FK: farthest TCP from the joint_2 axis over 20000 samples
    # the tray floor reachable top-down everywhere (scripts/workspace_reach.py koch 0.26)
    workspace_scale=0.26,
    object_scale=0.5,  # objects of 1.5-5 cm (the Panda's 3-10 cm): what a small jaw holds
    approach_in_base_plane=True,
    mount=(0.0, 0.0, 0.001),  # 1 mm clear of the table top, which the planner counts as touching
    # kg·m² per joint while grasping: without it the squeezing jaw left the wrist 0.15 rad
    # from its command through lift and hold (docs/robots.md)
    armature=0.01,
    # a small camera beside the jaw, looking along the fingers; held 0.12-0.16 m over the tray
    # floor (its straight-down reach ends at 0.16 m), the TCP 6 cm lower
    wrist_camera=tcp_camera("koch_tcp", side=0.03, back=0.06),
    look_scale=0.42,
)
