"""The ``robot`` section: which arm a tabletop scene has (``robot.name``, a built-in or plug-in
in :data:`datagen.registries.ROBOTS`), or a user's own arm from a URDF (``robot.urdf``) with no
code: its arm and finger joints, TCP link and opening range (docs/robots.md)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from datagen.assets.tabletop_layout import Workspace
from datagen.config.sections import ranged
from datagen.errors import ConfigError
from datagen.registries import ROBOTS
from datagen.robot_specs import GripperSpec, RobotSpec
from datagen.robot_specs.urdf import Urdf, read_urdf
from datagen.robot_specs.urdf_files import check_files


@dataclass(frozen=True)
class UrdfRobotConfig:
    file: str = ""  # a URDF, relative to the config file; "" uses robot.name's description
    arm_joints: tuple[str, ...] = ()  # the active joints that move the arm, base to flange
    finger_joints: tuple[str, ...] = ()  # the two prismatic finger joints (metres each)
    tcp_link: str = ""  # midway between the finger pads, z pointing out of the hand
    finger_travel: tuple[float, float] = field(
        default=(0.0, 0.04), metadata=ranged(0.0, 0.5, "metres each finger moves, closed..open")
    )
    ready_pose: tuple[float, ...] = ()  # radians per arm joint; () = each joint's mid-range
    srdf: str = ""  # collision pairs the planner may skip; "" = generated once and cached


ROBOT_POSES = ("look", "ready")


@dataclass(frozen=True)
class LookConfig:
    """Where ``robot.pose: look`` puts the wrist camera (lengths for the Panda's workspace,
    scaled with a small arm's)."""

    height: tuple[float, float] = field(
        default=(0.28, 0.38),
        metadata=ranged(0.05, 1.0, "wrist camera above the tray floor, metres"),
    )
    offset: float = field(
        default=0.04, metadata=ranged(0.0, 0.2, "look-at point from the tray centre, metres/axis")
    )
    tilt_deg: tuple[float, float] = field(
        default=(0.0, 15.0), metadata=ranged(0.0, 45.0, "view direction from straight down")
    )
    roll_deg: tuple[float, float] = field(
        default=(-20.0, 20.0), metadata=ranged(-180.0, 180.0, "image up from away-from-the-base")
    )


@dataclass(frozen=True)
class RobotConfig:
    name: str = "panda"
    pose: str = "look"  # look: wrist camera over the tray (robot.look); ready: the ready pose
    joint_jitter: float = field(
        default=0.15, metadata=ranged(0.0, 1.0, "radians around the ready pose, per arm joint")
    )
    look: LookConfig = field(default_factory=LookConfig)
    urdf: UrdfRobotConfig = field(default_factory=UrdfRobotConfig)


def robot_spec(cfg: RobotConfig, source: str = "<config>") -> RobotSpec:
    """The record of the configured arm; a ConfigError naming the key when it is not usable."""
    if cfg.pose not in ROBOT_POSES:
        raise ConfigError(
            f"{source}: robot.pose: expected one of {list(ROBOT_POSES)}, got {cfg.pose!r}"
        )
    if not cfg.urdf.file:
        return ROBOTS.check(cfg.name, f"{source}: robot.name").load()
    if cfg.name in ROBOTS:
        raise ConfigError(
            f"{source}: robot.name: a robot from robot.urdf.file needs a name of its own, "
            f"got the built-in {cfg.name!r}"
        )
    return urdf_robot(cfg.name, cfg.urdf, source)


def robot_workspace(cfg: RobotConfig) -> Workspace:
    """The table, tray and base scaled to the configured arm (``RobotSpec.workspace_scale``)."""
    return arm_workspace(robot_spec(cfg))


def arm_workspace(spec: RobotSpec) -> Workspace:
    """The table, tray and base scaled to the arm ``spec``."""
    return Workspace(spec.workspace_scale, spec.object_scale)


def user_urdf(file: str, source: str) -> Urdf:
    """The user's URDF, checked before any process loads it: bounded XML, every number finite
    and in range, one tree, each mesh and texture a bounded regular file (docs/robots.md)."""
    path = Path(file)
    if not path.is_file():
        raise ConfigError(f"{source}: robot.urdf.file: expected a URDF file, got {file!r}")
    try:
        urdf = read_urdf(path.resolve())
        check_files(path.resolve())
    except ConfigError as error:
        raise ConfigError(f"{source}: robot.urdf.file: {error}") from None
    return urdf


def urdf_robot(name: str, cfg: UrdfRobotConfig, source: str) -> RobotSpec:
    path = Path(cfg.file)
    urdf = user_urdf(cfg.file, source)
    moving = ("revolute", "continuous", "prismatic")
    arm = [_joint(urdf, j, moving, "arm_joints", source) for j in cfg.arm_joints]
    if not arm:
        raise ConfigError(f"{source}: robot.urdf.arm_joints: expected the arm's joint names")
    fingers = [_joint(urdf, j, ("prismatic",), "finger_joints", source) for j in cfg.finger_joints]
    if len(fingers) != 2 or fingers[0].parent != fingers[1].parent:
        raise ConfigError(
            f"{source}: robot.urdf.finger_joints: expected two prismatic joints on one hand link, "
            f"got {list(cfg.finger_joints)}"
        )
    if cfg.tcp_link not in urdf.links:
        raise ConfigError(
            f"{source}: robot.urdf.tcp_link: expected a link of {path.name}, got {cfg.tcp_link!r}"
        )
    limits = [j.limits or (-np.pi, np.pi) for j in arm]
    ready = cfg.ready_pose or tuple(round((lo + hi) / 2, 6) for lo, hi in limits)
    if len(ready) != len(arm):
        raise ConfigError(
            f"{source}: robot.urdf.ready_pose: expected {len(arm)} values (one per arm joint), "
            f"got {len(ready)}"
        )
    gripper = GripperSpec(
        hand_link=fingers[0].parent,
        tcp_link=cfg.tcp_link,
        finger_links=(fingers[0].child, fingers[1].child),
        finger_joints=(fingers[0].name, fingers[1].name),
        finger_travel=cfg.finger_travel,
    )
    return RobotSpec(
        name=name,
        summary=f"a user's arm from {path.name}",
        description=str(path.resolve()),
        licence="the user's",
        arm_joints=tuple(cfg.arm_joints),
        ready_pose=tuple(float(v) for v in ready),
        gripper=gripper,
        reach=chain_length(urdf, cfg.tcp_link),
        srdf=str(Path(cfg.srdf).resolve()) if cfg.srdf else None,
    )


def _joint(urdf: Urdf, name: str, kinds: tuple[str, ...], key: str, source: str):
    joint = urdf.joints.get(name)
    if joint is None or joint.kind not in kinds:
        raise ConfigError(
            f"{source}: robot.urdf.{key}: expected {' or '.join(kinds)} joints of the URDF, "
            f"got {name!r}" + ("" if joint is None else f" ({joint.kind})")
        )
    return joint


def chain_length(urdf: Urdf, link: str) -> float:
    """Metres along the joint origins from the root to ``link``: an upper bound of its reach."""
    parents = {j.child: j for j in urdf.joints.values()}
    total = 0.0
    while link in parents:
        joint = parents[link]
        total += float(np.linalg.norm(joint.origin[:3, 3]))
        link = joint.parent
    return round(total, 4)
