"""TheRobotStudio SO-100, as ManiSkill ships it (``robots/so100/so100.urdf`` and its SRDF): five
arm joints and a jaw gripper, the revolute ``gripper`` joint swinging ``Moving_Jaw`` against the
jaw of ``Fixed_Jaw``. Composed on first use with a TCP and two pad frames in datagen's convention
and turned to face +x (:mod:`datagen.robot_specs.compose`)."""

from __future__ import annotations

import math
from pathlib import Path

from datagen.robot_specs import GripperSpec, RobotSpec, tcp_camera
from datagen.robot_specs.compose import Frame, FrameComposition, compose_framed_urdf

COMPOSITION = FrameComposition(
    name="so100",
    source="mani_skill:robots/so100/so100.urdf",
    frames=(
        # midway between the pads at half opening (gripper -0.43 rad); z along the jaws (-y of
        # Fixed_Jaw), y from the fixed jaw to the moving one (-x of Fixed_Jaw)
        Frame("so100_tcp", "Fixed_Jaw", (-0.0171, -0.09606, 0.0), (math.pi / 2, -math.pi / 2, 0.0)),
        # on the inner faces of the collision shapes, at the depth of ManiSkill's jaw tips
        Frame("so100_fixed_pad", "Fixed_Jaw", (0.0079, -0.097, 0.0)),
        Frame("so100_moving_pad", "Moving_Jaw", (-0.0123, -0.073, 0.0)),
    ),
    base_yaw=math.pi / 2,  # ManiSkill's so100 faces -y of its Base
)


def urdf() -> Path:
    return compose_framed_urdf(COMPOSITION)


SO100 = RobotSpec(
    name="so100",
    summary="TheRobotStudio SO-100 low-cost arm with its jaw gripper (ManiSkill's so100)",
    description="composed:datagen.robot_specs.so100:urdf",
    srdf="mani_skill:robots/so100/so100.srdf",
    licence="Apache-2.0 (TheRobotStudio SO-ARM100, as shipped by ManiSkill)",
    arm_joints=("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"),
    # arm raised, jaws pointing down: TCP ~(0.17, 0, 0.11) m from the base; wrist_flex near
    # its limit of 1.8 rad
    ready_pose=(0.145, -0.51, 0.277, 1.75, 1.804),
    gripper=GripperSpec(
        hand_link="Fixed_Jaw",
        tcp_link="so100_tcp",
        finger_links=("Moving_Jaw", "Fixed_Jaw"),
        finger_joints=("gripper",),
        # closed .. 0.6 rad: the width grows to 0.100 m; past ~0.85 rad it shrinks again
        finger_travel=(-1.1, 0.6),
        pad_links=("so100_moving_pad", "so100_fixed_pad"),
        drive=(100.0, 10.0, 1.0),  # N·m/rad, N·m·s/rad, N·m: 15-20 N between the jaw tips
        friction=2.0,  # as ManiSkill's so100 jaws: the default 0.3 lets a lifted object slip
    ),
    reach=0.45,  # FK: farthest TCP from the shoulder_lift axis over 20000 samples
    # the tray floor reachable top-down everywhere (scripts/workspace_reach.py so100 0.33)
    workspace_scale=0.33,
    object_scale=0.5,  # objects of 1.5-5 cm (the Panda's 3-10 cm): what a small jaw holds
    approach_in_base_plane=True,
    mount=(0.0, 0.0, 0.001),  # 1 mm clear of the table top, which the planner counts as touching
    # kg·m² per joint while grasping: without it the squeezing jaw left the wrist 0.15 rad
    # from its command through lift and hold (docs/robots.md)
    armature=0.01,
    # a small camera beside the jaw, looking along the fingers; held 0.12-0.16 m over the tray
    # floor (its straight-down reach ends at 0.16 m), the TCP 6 cm lower
    wrist_camera=tcp_camera("so100_tcp", side=0.03, back=0.06),
    look_scale=0.42,
)
