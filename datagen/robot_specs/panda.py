"""Franka Emika Panda, as ManiSkill ships it (``robots/panda/panda_v2.urdf`` and its SRDF)."""

from __future__ import annotations

from datagen.robot_specs import LOOKING_ALONG_Z, CameraMount, GripperSpec, RobotSpec

FRANKA_HAND = GripperSpec(
    hand_link="panda_hand",
    tcp_link="panda_hand_tcp",
    finger_links=("panda_leftfinger", "panda_rightfinger"),
    finger_joints=("panda_finger_joint1", "panda_finger_joint2"),
    finger_travel=(0.0, 0.04),
)

# ManiSkill's panda_wristcam, on the Franka hand
FRANKA_WRIST_CAMERA = CameraMount(
    link="panda_hand",
    position=(0.0464982, -0.0200011, 0.0360011),
    quat_wxyz=LOOKING_ALONG_Z,
    fovy_deg=58.0,
    near=0.01,
)

PANDA = RobotSpec(
    name="panda",
    summary="Franka Emika Panda with its hand (ManiSkill's panda_v2)",
    description="mani_skill:robots/panda/panda_v2.urdf",
    srdf="mani_skill:robots/panda/panda_v2.srdf",
    licence="Apache-2.0 (franka_ros description, as shipped by ManiSkill)",
    arm_joints=tuple(f"panda_joint{i}" for i in range(1, 8)),
    # arm raised and folded back so the tray stays in view
    ready_pose=(0.0, -0.95, 0.0, -2.75, 0.0, 1.95, 0.785),
    gripper=FRANKA_HAND,
    reach=0.855,
    wrist_camera=FRANKA_WRIST_CAMERA,
)
