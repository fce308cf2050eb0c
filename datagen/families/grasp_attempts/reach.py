"""Whether the arm reaches a grasp candidate, planned as execution plans it, before anything
moves: collision-free IK at the pre-grasp pose (the same fixed seeds, the scene's objects and
static boxes in the way), then a straight approach from one of those solutions to the grasp
pose with the objects removed (physics decides about contacts there). A transit the IK allows
may still fail to plan, and a lift may fail after the grasp: those stay ``unreachable`` labels.
Deterministic, so an attempt is still a function of (seed, index)."""

from __future__ import annotations

import numpy as np

from datagen.families.grasp_attempts.execute import ExecutionParams, planned_poses
from datagen.families.grasp_attempts.grasps import GraspCandidate
from datagen.families.grasp_attempts.gripper_geometry import gripper_geometry
from datagen.families.grasp_attempts.planner import (
    make_planner,
    plan_straight,
    remove_obstacles,
    solve_ik,
)
from datagen.families.grasp_tabletop.world import GraspScene


class ArmReach:
    """``reach(candidate)``: True when the arm reaches it in ``scene`` as it stands now."""

    def __init__(self, scene: GraspScene, params: ExecutionParams):
        self.geometry = gripper_geometry(scene.spec)
        self.params = params
        self.qpos = np.asarray(scene.robot.get_qpos(), float)
        self.time_step = scene.scene.get_timestep()
        self.clear = make_planner(scene.scene, scene.robot, scene.objects, scene.spec)
        self.free = make_planner(scene.scene, scene.robot, scene.objects, scene.spec)
        remove_obstacles(self.free)

    def __call__(self, candidate: GraspCandidate) -> bool:
        _, _, pre, grasp = planned_poses(candidate, self.geometry, self.params)
        return any(
            plan_straight(self.free, grasp, q, self.time_step)["status"] == "Success"
            for q in solve_ik(self.clear, pre, self.qpos)
        )
