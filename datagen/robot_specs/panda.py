"""Franka Emika Panda, as ManiSkill ships it (``robots/panda/panda_v2.urdf``)."""

from __future__ import annotations

from datagen.robot_specs import CameraMount, GripperSpec, RobotSpec

PANDA = RobotSpec(
    name="panda",
    description="robots/panda/panda_v2.urdf",
    arm_joints=7,
    # arm raised and folded back so the tray stays in view
    ready_pose=(0.0, -0.95, 0.0, -2.75, 0.0, 1.95, 0.785),
    gripper=GripperSpec(
        hand_link="panda_hand",
        tcp_link="panda_hand_tcp",
        finger_links=("panda_leftfinger", "panda_rightfinger"),
        finger_travel=(0.0, 0.04),
        tcp_from_hand=0.1034,
        finger_origin=0.0584,
        pad=(0.0175, 0.0152, 0.0185),
        pad_centre=0.04525,
        finger_body=(0.022, 0.022, 0.038),
        finger_body_start=0.001,
        finger_body_gap=0.004,
        hand_bounds=((-0.0317, -0.1040, -0.0260), (0.0317, 0.1005, 0.0660)),  # hand.stl
    ),
    # ManiSkill's panda_wristcam
    wrist_camera=CameraMount(
        link="panda_hand",
        position=(0.0464982, -0.0200011, 0.0360011),
        quat_wxyz=(0, 0.70710678, 0, 0.70710678),
        fovy_deg=70.0,
        near=0.01,
    ),
)
