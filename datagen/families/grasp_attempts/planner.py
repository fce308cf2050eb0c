"""Deterministic mplib planning for the arm's TCP link (its record's ``gripper.tcp_link``) in a
grasping scene.

Transit to the pre-grasp pose avoids the scene's static boxes (table, legs, tray) and every
object's oriented bounding box; straight-line (screw) moves ignore them, so that the physics
simulation, not the planner, decides whether an approach collides. mplib 0.1.1 has no seed:
its IK restarts from random configurations and RRT is random. Here IK starts from a fixed seed
list and transit first tries a collision-checked straight joint-space path; RRT is only a
fallback, reported as such.
"""

from __future__ import annotations

import logging
from typing import Any

import mplib
import numpy as np
import sapien
from mplib.pymp.collision_detection import fcl

from datagen.families.grasp_tabletop.world import SceneObject
from datagen.robot_specs import RobotSpec
from datagen.robot_specs.compose import generated_srdf
from datagen.robot_specs.planner_copy import planner_urdf

log = logging.getLogger(__name__)

N_RANDOM_IK_SEEDS = 12
INTERP_STEP = 0.02  # radians between collision checks on a straight joint-space path


def pose7(pose: sapien.Pose) -> np.ndarray:
    return np.concatenate([pose.p, pose.q]).astype(np.float64)


class ArmPlanner(mplib.Planner):
    """mplib's planner for one arm, which also knows the arm's ready pose (radians): the IK's
    second seed, after the current joints."""

    def __init__(self, ready_pose: tuple[float, ...], **kwargs: Any):
        super().__init__(**kwargs)
        self.ready_pose = ready_pose


def make_planner(
    scene: sapien.Scene,
    robot: sapien.physx.PhysxArticulation,
    objects: list[SceneObject],
    spec: RobotSpec,
) -> ArmPlanner:
    urdf = planner_urdf(spec)  # a user's arm: a copy in the cache, with convex hulls
    srdf = spec.srdf_path() or generated_srdf(urdf)
    planner = ArmPlanner(
        spec.ready_pose,
        urdf=str(urdf),
        srdf=str(srdf),
        user_link_names=[link.get_name() for link in robot.get_links()],
        user_joint_names=[joint.get_name() for joint in robot.get_active_joints()],
        move_group=spec.gripper.tcp_link,
    )
    planner.set_base_pose(pose7(robot.get_root_pose()))
    planner.joint_vel_limits = np.asarray(planner.joint_vel_limits) * 0.9
    planner.joint_acc_limits = np.asarray(planner.joint_acc_limits) * 0.9
    for name, size, pose in _obstacles(scene, objects):
        planner.set_normal_object(name, fcl.CollisionObject(fcl.Box(size), pose.p, pose.q))
    return planner


def _static_box(shape: sapien.physx.PhysxCollisionShape) -> tuple[np.ndarray, sapien.Pose] | None:
    """(full size, pose in the body) of a static box, or of a convex mesh's bounds in its frame
    (a campaign's static boxes are convex meshes of their corners: datagen.families.grasp_attempts.contacts)."""
    if isinstance(shape, sapien.physx.PhysxCollisionShapeBox):
        return 2 * np.asarray(shape.half_size, float), shape.get_local_pose()
    if isinstance(shape, sapien.physx.PhysxCollisionShapeConvexMesh):
        vertices = np.asarray(shape.get_vertices(), float) * np.asarray(shape.get_scale(), float)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        return hi - lo, shape.get_local_pose() * sapien.Pose((lo + hi) / 2)
    return None


def _obstacles(scene: sapien.Scene, objects: list[SceneObject]):
    """(name, full box size, world pose) of static boxes and object bounding boxes."""
    for i, entity in enumerate(scene.get_entities()):
        body = entity.find_component_by_type(sapien.physx.PhysxRigidStaticComponent)
        if body is None:
            continue
        for j, shape in enumerate(body.get_collision_shapes()):
            box = _static_box(shape)
            if box is not None:
                yield f"static_{i}_{j}", box[0], entity.get_pose() * box[1]
    for obj in objects:
        pose = obj.entity.get_pose() * sapien.Pose(obj.geometry.obb_transform)
        yield f"object_{obj.instance_id}", np.asarray(obj.geometry.obb_extents, float), pose


def remove_obstacles(planner: mplib.Planner) -> None:
    for name in list(planner.planning_world.get_normal_object_names()):
        planner.remove_normal_object(name)


def _ik_seeds(planner: ArmPlanner, qpos: np.ndarray) -> list[np.ndarray]:
    lo, hi = np.asarray(planner.joint_limits, float).reshape(-1, 2).T
    arm = planner.move_group_joint_indices
    ready = qpos.copy()
    ready[arm] = planner.ready_pose
    rng = np.random.default_rng(0)  # a fixed list, not a source of randomness between runs
    randoms = []
    for _ in range(N_RANDOM_IK_SEEDS):
        q = qpos.copy()
        q[arm] = np.where(np.isfinite(lo + hi), rng.uniform(lo, hi), qpos)[arm]
        randoms.append(q)
    return [qpos.copy(), ready, *randoms]


def solve_ik(planner: ArmPlanner, pose: sapien.Pose, qpos: np.ndarray) -> list[np.ndarray]:
    """Collision-free IK solutions (full qpos) from fixed seeds, nearest to ``qpos`` first."""
    goal = planner.transform_goal_to_wrt_base(pose7(pose))
    idx = planner.move_group_joint_indices
    solutions: list[np.ndarray] = []
    for seed in _ik_seeds(planner, qpos):
        status, found = planner.IK(goal, seed.astype(np.float64), n_init_qpos=1)
        if status == "Success":
            q = np.asarray(found[0], float)
            if all(np.linalg.norm(q[idx] - s[idx]) > 0.1 for s in solutions):
                solutions.append(q)
    solutions.sort(key=lambda q: float(np.linalg.norm(q[idx] - qpos[idx])))
    return solutions


def straight_path_free(planner: mplib.Planner, start: np.ndarray, goal: np.ndarray) -> bool:
    """Whether the straight joint-space path from ``start`` to ``goal`` (the move group's
    joints, radians) is collision-free, checked every ``INTERP_STEP``."""
    n = max(2, int(np.ceil(np.abs(goal - start).max() / INTERP_STEP)) + 1)
    for q in np.linspace(start, goal, n):
        planner.planning_world.set_qpos_all(q)
        if planner.planning_world.collide():
            return False
    return True


def plan_transit(
    planner: ArmPlanner, pose: sapien.Pose, qpos: np.ndarray, time_step: float
) -> dict[str, Any]:
    """Trajectory of the arm joints to ``pose``; ``status`` is "Success" or why it failed."""
    qpos = np.asarray(qpos, float)
    idx = planner.move_group_joint_indices
    solutions = solve_ik(planner, pose, qpos)
    if not solutions:
        return {"status": "IK failed", "method": "ik"}
    for goal in solutions:
        if straight_path_free(planner, qpos[idx], goal[idx]):
            path = np.linspace(qpos[idx], goal[idx], 8)
            _, pos, vel, _, _ = planner.TOPP(path, time_step)
            return {"status": "Success", "method": "joint_line", "position": pos, "velocity": vel}
    result = planner.plan_qpos_to_qpos(solutions, qpos.copy(), time_step=time_step, planning_time=1)
    return result | {"method": "rrt_connect"}


def plan_straight(
    planner: mplib.Planner, pose: sapien.Pose, qpos: np.ndarray, time_step: float
) -> dict[str, Any]:
    """Straight-line (screw) trajectory of the TCP to ``pose``; deterministic."""
    result = planner.plan_screw(pose7(pose), np.asarray(qpos, float), time_step=time_step)
    return result | {"method": "screw"}
