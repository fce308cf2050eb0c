"""Robot randomiser: the arm's initial joint configuration around its ready pose and, with
``robot.pose: look``, where its wrist camera looks at the tray from (the world finds the
joints that put it there: :mod:`datagen.worlds.look_pose`)."""

from __future__ import annotations

import numpy as np

from datagen.assets.tabletop_layout import Workspace
from datagen.config.robot import LookConfig, RobotConfig, robot_spec
from datagen.robot_specs import RobotSpec
from datagen.scene_values.arm import ArmPose, WristLook


def draw_robot(
    rng: np.random.Generator,
    cfg: RobotConfig,
    ws: Workspace,
    aim: np.ndarray | None = None,
    spec: RobotSpec | None = None,
) -> ArmPose:
    """Joint positions: the arm's ready pose jittered, the finger joints (two prismatic fingers,
    or one jaw) opened alike within their travel (radians, metres), in the order of the record's
    ``joint_names``; and with ``robot.pose: look`` the wrist camera's ``look`` (world metres),
    aimed towards ``aim`` (world x, y: where the objects were dropped) when given. ``spec``:
    the configured arm, resolved (else resolved here)."""
    spec = spec or robot_spec(cfg)
    ready = spec.ready_pose
    arm = np.asarray(ready) + rng.uniform(-cfg.joint_jitter, cfg.joint_jitter, len(ready))
    finger = float(rng.uniform(*spec.gripper.finger_travel))
    fingers = [finger] * len(spec.gripper.finger_joints)
    qpos = tuple(np.round(np.append(arm, fingers), 6).tolist())
    if cfg.pose != "look":
        return ArmPose(qpos)
    look = draw_wrist_look(rng, cfg.look, ws, spec.approach_in_base_plane, spec.look_scale, aim)
    return ArmPose(qpos, look)


def draw_wrist_look(
    rng: np.random.Generator,
    cfg: LookConfig,
    ws: Workspace,
    in_base_plane: bool,
    look_scale: float = 1.0,
    aim: np.ndarray | None = None,
) -> WristLook:
    """The wrist camera's ``eye``, the ``target`` it looks at on the tray floor (within
    ``offset`` of the tray's centre, or of ``aim`` brought within half the tray's inner half of
    it) and the world direction its image's ``up`` turns towards (metres, world frame; heights
    times ``look_scale``, ``RobotSpec.look_scale``, offsets times the workspace's scale). The
    eye leans up to
    ``tilt_deg`` from straight above the target, to the base's side, and the image's up turns by
    up to ``roll_deg`` from pointing away from the base (world +x). An arm whose approach must
    lie in the vertical plane through its shoulder (``RobotSpec.approach_in_base_plane``) looks
    straight down: a leaning view would need the approach out of that plane."""
    centre = np.asarray(ws.tray_floor_top, float)
    if aim is not None:  # towards the objects, at most half the tray's inner half off its centre
        half = np.asarray(ws.tray_inner_half, float) / 2
        centre[:2] += np.clip(np.asarray(aim, float) - centre[:2], -half, half)
    target = centre + np.append(rng.uniform(-1, 1, 2) * cfg.offset * ws.scale, 0.0)
    height = rng.uniform(*cfg.height) * look_scale
    tilt = np.deg2rad(rng.uniform(*cfg.tilt_deg)) * (not in_base_plane)
    back = np.asarray(ws.robot_base[:2], float) - target[:2]  # the eye leans towards the base,
    azimuth = np.arctan2(back[1], back[0]) + rng.uniform(-np.pi / 2, np.pi / 2)  # within reach
    lean = np.array([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), np.cos(tilt)])
    eye = target + lean * height / np.cos(tilt)
    roll = np.deg2rad(rng.uniform(*cfg.roll_deg))
    up = [np.cos(roll), np.sin(roll), 0.0]
    return WristLook(
        eye=tuple(np.round(eye, 6).tolist()),
        target=tuple(np.round(target, 6).tolist()),
        up=tuple(np.round(up, 6).tolist()),
    )
