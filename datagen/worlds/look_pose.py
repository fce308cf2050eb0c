"""The arm's look pose (``robot.pose: look``): the joint positions that put the wrist camera
where the robot randomiser drew it, over the tray looking down at it, found by inverse
kinematics of the arm's own description (mplib's Pinocchio model; no simulator object)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import transforms3d.quaternions as tq
from mplib.pymp.kinematics.pinocchio import PinocchioModel

from datagen.geometry import look_at
from datagen.robot_specs import CameraMount, RobotSpec, wrist_mount
from datagen.scene_values.arm import WristLook

IK_TOLERANCE = 1e-4  # norm of the remaining SE(3) error (metres, radians)
N_FIXED_STARTS = 8  # starts after the sampled and the ready pose


class LookPoseUnreachable(ValueError):
    """No joint positions within the limits put the wrist camera at the drawn pose."""


@lru_cache(maxsize=8)
def _kinematics(spec: RobotSpec) -> PinocchioModel:
    model = PinocchioModel(str(spec.urdf_path()), verbose=False)
    model.set_joint_order(list(spec.joint_names))
    return model


def mount_transform(mount: CameraMount) -> np.ndarray:
    """(4, 4) the camera's pose in its link's frame (SAPIEN camera axes: x ahead, z up)."""
    transform = np.eye(4)
    transform[:3, :3] = tq.quat2mat(mount.quat_wxyz)
    transform[:3, 3] = mount.position
    return transform


def look_qpos(
    spec: RobotSpec, base_position: np.ndarray, look: WristLook, qpos: tuple[float, ...]
) -> list[float]:
    """Joint positions (``spec.joint_names`` order, fingers as in ``seed_qpos``) whose wrist
    camera sits at ``look.eye`` looking at ``look.target`` with the image's up towards
    ``look.up`` (world metres; the base unrotated at ``base_position``). The IK starts from
    ``qpos`` (the jittered ready pose: it picks the elbow of a redundant arm), then from
    the ready pose, then fixed others; raises :class:`LookPoseUnreachable` when none converges
    within the joint limits."""
    mount = wrist_mount(spec)
    camera = look_at(look.eye, look.target, look.up)
    link = camera @ np.linalg.inv(mount_transform(mount))
    link[:3, 3] = link[:3, 3] - np.asarray(base_position, float)
    goal = np.concatenate([link[:3, 3], tq.mat2quat(link[:3, :3])])
    model = _kinematics(spec)
    limits = map(_limits, model.get_joint_limits())
    lower, upper = (np.concatenate(v) for v in zip(*limits, strict=True))
    index = model.get_link_names().index(mount.link)
    for start in _starts(spec, np.asarray(qpos, float), lower, upper):
        q, _, error = model.compute_IK_CLIK(index, goal, start, eps=IK_TOLERANCE, max_iter=1000)
        q = _wrapped(q, lower, upper)
        if np.linalg.norm(error) < IK_TOLERANCE and np.all((lower <= q) & (q <= upper)):
            return np.round(q, 6).tolist()
    raise LookPoseUnreachable(
        f"robot.pose: look: the {spec.name}'s wrist camera cannot reach the drawn pose (eye "
        f"{list(look.eye)}, target {list(look.target)}; robot.look sets the range)"
    )


def _starts(spec: RobotSpec, qpos: np.ndarray, lower: np.ndarray, upper: np.ndarray):
    """Where the IK starts: ``qpos``, the ready pose, then a fixed list of arm configurations
    drawn within the limits (a fixed list, not a source of randomness between samples)."""
    arm = len(spec.ready_pose)
    ready = qpos.copy()
    ready[:arm] = spec.ready_pose
    yield from (qpos, ready)
    fixed = np.random.default_rng(0)
    for _ in range(N_FIXED_STARTS):
        start = qpos.copy()
        start[:arm] = fixed.uniform(np.maximum(lower, -np.pi), np.minimum(upper, np.pi))[:arm]
        yield start


def _wrapped(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``q`` with each angle moved by whole turns into its limits where a turn gets it there."""
    turns = np.where(q > upper, -1, np.where(q < lower, 1, 0)) * 2 * np.pi
    return np.where((lower <= q + turns) & (q + turns <= upper), q + turns, q)


def _limits(joint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) of one joint's (dof, 2) limits; a continuous joint's are +-inf."""
    joint = np.asarray(joint, float).reshape(-1, 2)
    return np.nan_to_num(joint[:, 0], neginf=-1e6), np.nan_to_num(joint[:, 1], posinf=1e6)
