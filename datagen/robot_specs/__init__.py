"""What datagen knows of each robot, as plain values (no simulator), one module per robot
(:mod:`datagen.robot_specs.panda`, ...) and one line in :data:`datagen.registries.ROBOTS`: its
description file, joints, links, gripper, ready pose, mount, reach, licence and camera mount.
The worlds, the randomisers, grasping, the exports and the sample metadata ask the robot's
record, so each fact is written once (docs/robots.md).

A description is located by a string: ``mani_skill:<path>`` (a file shipped in the mani-skill
wheel, under ``mani_skill/assets/``), ``datagen:<path>`` (a file shipped in this package, under
``datagen/robot_specs/descriptions/``), ``composed:<module:function>`` (a function writing a
description put together from shipped parts, returning its path), or a file path (a user's URDF).
"""

from __future__ import annotations

import importlib
import importlib.util
from dataclasses import dataclass
from pathlib import Path

Vector3 = tuple[float, float, float]
DESCRIPTIONS = Path(__file__).parent / "descriptions"
# the PD drive that holds a scene's robot at its sampled joint positions (and that a USD stage
# carries): stiffness N·m/rad or N/m, damping N·m·s/rad or N·s/m
HOLD_STIFFNESS, HOLD_DAMPING = 2000.0, 200.0


@dataclass(frozen=True)
class GripperSpec:
    """A two-finger gripper: two prismatic fingers sliding along +-y of the TCP frame, or a jaw
    gripper, one revolute joint swinging one finger against the other, which is part of the
    hand. z of the TCP frame points out of the hand along the fingers, y is the closing
    direction, from ``pads[1]`` to ``pads[0]``. The geometry the grasp samplers check, the
    opening (width) of each joint value and the grasp frame are derived from the description
    (:mod:`datagen.families.grasp_attempts.gripper_geometry`)."""

    hand_link: str
    tcp_link: str  # the motion planner's move group: midway between the pads (at half opening)
    finger_links: tuple[str, str]  # a jaw gripper: (the moving jaw, the link holding the fixed one)
    finger_joints: tuple[str, ...]  # two prismatic (metres each) or one revolute (radians)
    finger_travel: tuple[float, float]  # the joint(s) closed .. fully open, metres or radians
    # the links whose origins lie on the fingers' inner faces; the width is their distance
    # along y (None: the finger links, as for the Franka hand, whose origins meet when closed)
    pad_links: tuple[str, str] | None = None
    # the finger joints' drive (stiffness, damping, force limit; N/m, N·s/m, N or N·m/rad,
    # N·m·s/rad, N·m) while grasping; None: ExecutionParams.gripper_drive (1e3, 1e2, 100), which
    # a small jaw closes with a hundredfold too hard, squeezing the object out
    drive: tuple[float, float, float] | None = None
    # static and dynamic friction (restitution 0) of the gripper links' collision shapes from the
    # start of a grasp attempt (ManiSkill gives the SO-100's jaws 2); None: SAPIEN's default
    # material (0.3, restitution 0.1)
    friction: float | None = None

    @property
    def jaw(self) -> bool:
        """One revolute joint: the width is a function of the jaw angle read from the URDF."""
        return len(self.finger_joints) == 1

    @property
    def pads(self) -> tuple[str, str]:
        return self.pad_links or self.finger_links

    @property
    def links(self) -> tuple[str, ...]:
        """The links labelled ``gripper`` (not ``robot``) in the annotations."""
        return tuple(dict.fromkeys((self.hand_link, self.tcp_link, *self.finger_links)))


@dataclass(frozen=True)
class CameraMount:
    """A camera fixed to a robot link (pose in the link's frame, SAPIEN's camera axes)."""

    link: str
    position: Vector3
    quat_wxyz: tuple[float, float, float, float]
    fovy_deg: float
    near: float  # metres


# a camera's forward (SAPIEN's x) along the link's z, its up (z) along the link's x
LOOKING_ALONG_Z = (0.0, 0.70710678, 0.0, 0.70710678)


def tcp_camera(link: str, side: float, back: float) -> CameraMount:
    """A wrist camera on the TCP link, ``back`` metres behind the TCP and ``side`` metres along
    its x (off the fingers' closing plane), looking along the fingers (58° vertical field)."""
    return CameraMount(link, (side, 0.0, -back), LOOKING_ALONG_Z, 58.0, 0.01)


@dataclass(frozen=True)
class RobotSpec:
    name: str
    summary: str  # one line, shown in docs/robots.md
    description: str  # where its URDF is (module docstring)
    licence: str  # of the description and its meshes
    arm_joints: tuple[str, ...]  # the active joints that move the arm, base to flange
    ready_pose: tuple[float, ...]  # the arm joints (radians) a scene starts around
    gripper: GripperSpec
    reach: float  # metres from the base's mount to the farthest TCP position
    srdf: str | None = None  # located like ``description``; None: collision pairs generated
    mount: Vector3 = (0.0, 0.0, 0.0)  # metres added to the world's robot base position
    wrist_camera: CameraMount | None = None  # None: DEFAULT_WRIST_CAMERA on the TCP link
    # a small arm's tabletop: table, tray, base position and camera scaled about the world
    # origin so that it reaches the whole tray floor; 1.0 keeps the Panda-sized scene
    workspace_scale: float = 1.0
    # object sizes and drop heights: set by the gripper (which does not shrink with the arm)
    object_scale: float = 1.0
    # the wrist camera's height over the tray (robot.look.height), against the Panda's: a small
    # arm holds it straight down no higher than its reach allows, its jaw clear of the objects
    look_scale: float = 1.0
    # five arm joints (pan, three pitches, wrist roll): a grasp's approach must lie in the
    # vertical plane through the base, which the antipodal sampler then keeps to
    approach_in_base_plane: bool = False
    # kg·m² added to every active joint's inertia from the start of a grasp attempt (a servo's
    # rotor seen through its gearbox); 0: the links' own. A jaw squeezing an object between
    # links of 1e-5 kg·m² left the solver's error in the arm joints (so100: 0.14 rad)
    armature: float = 0.0

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The sampled and recorded joint order: the arm's, then the fingers'."""
        return (*self.arm_joints, *self.gripper.finger_joints)

    @property
    def description_path(self) -> str:
        """The description as the sample metadata names it (no machine path)."""
        scheme, _, rest = self.description.partition(":")
        if scheme == "mani_skill":
            return f"mani_skill/assets/{rest}"
        if scheme == "datagen":
            return f"datagen/robot_specs/descriptions/{rest}"
        if scheme == "composed":
            return f"datagen:{self.name}"
        return Path(self.description).name

    def urdf_path(self) -> Path:
        return locate(self.description)

    def srdf_path(self) -> Path | None:
        return None if self.srdf is None else locate(self.srdf)


def maniskill_asset(relative: str) -> Path:
    """``mani_skill/assets/<relative>``; a clear error if mani-skill is missing."""
    spec = importlib.util.find_spec("mani_skill")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError(f"mani-skill is not installed: it provides {relative}")
    return Path(spec.submodule_search_locations[0]) / "assets" / relative


def locate(where: str) -> Path:
    """The file a description string names (module docstring)."""
    scheme, _, rest = where.partition(":")
    if scheme == "mani_skill":
        return maniskill_asset(rest)
    if scheme == "datagen":
        return DESCRIPTIONS / rest
    if scheme == "composed":
        module, _, function = rest.partition(":")
        return Path(getattr(importlib.import_module(module), function)())
    return Path(where)


def wrist_mount(spec: RobotSpec) -> CameraMount:
    """The robot's wrist camera: its record's, else one on the TCP link 10 cm behind the TCP."""
    return spec.wrist_camera or tcp_camera(spec.gripper.tcp_link, side=0.05, back=0.1)
