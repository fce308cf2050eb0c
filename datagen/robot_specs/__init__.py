"""What datagen knows of each robot, as plain values (no simulator), one module per robot
(:mod:`datagen.robot_specs.panda`): its description file, joints, links, gripper geometry,
ready pose and camera mount. The worlds, the randomisers, grasping and the sample metadata all
ask the robot's record, so each fact is written once.
"""

from __future__ import annotations

from dataclasses import dataclass

Vector3 = tuple[float, float, float]


@dataclass(frozen=True)
class GripperSpec:
    """A parallel gripper, in its hand link's frame (metres): the fingers slide along +-y, z points
    out of the hand towards the tool centre point (TCP)."""

    hand_link: str
    tcp_link: str  # the TCP: midway between the finger pads, the motion planner's move group
    finger_links: tuple[str, str]
    finger_travel: tuple[float, float]  # metres each finger moves, closed .. fully open
    tcp_from_hand: float  # the TCP along z
    finger_origin: float  # the finger joints along z
    pad: Vector3  # a finger's rubber tip box (x, y thickness, z length)
    pad_centre: float  # along z from the finger joints
    finger_body: Vector3  # the box around a finger's diagonal and screw mount
    finger_body_start: float  # its near end along z from the finger joints
    finger_body_gap: float  # along y between a pad's inner face and the body
    hand_bounds: tuple[Vector3, Vector3]  # the hand's collision mesh (lower, upper corners)

    @property
    def max_width(self) -> float:
        """Metres between the finger pads, fully open."""
        return 2 * self.finger_travel[1]


@dataclass(frozen=True)
class CameraMount:
    """A camera fixed to a robot link (pose in the link's frame, SAPIEN's camera axes)."""

    link: str
    position: Vector3
    quat_wxyz: tuple[float, float, float, float]
    fovy_deg: float
    near: float  # metres


@dataclass(frozen=True)
class RobotSpec:
    name: str
    description: str  # its URDF under ``mani_skill/assets/`` (the SRDF beside it)
    arm_joints: int  # the first active joints move the arm; the fingers' follow
    ready_pose: tuple[float, ...]  # the arm joints (radians) a scene starts around
    gripper: GripperSpec
    wrist_camera: CameraMount

    @property
    def description_path(self) -> str:
        """The description as the sample metadata names it."""
        return f"mani_skill/assets/{self.description}"
