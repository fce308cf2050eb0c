"""Whether the arm reaches a grasp candidate, planned as execution plans it, before anything
moves: collision-free IK at the pre-grasp pose (the same fixed seeds, the scene's objects and
static boxes in the way); the transit's goal among those solutions, as execution picks it (the
first with a collision-free straight joint path from where the arm stands; when none has one,
execution plans RRT to any of them, so any will do); from there a straight approach to the
grasp pose and a straight lift of ``lift_height`` in world z, with the objects removed (physics
decides about contacts there). The lift is planned from the approach's end, not from where the
closed fingers leave the hand, so a lift may still fail after the grasp. Deterministic, so an
attempt is still a function of (seed, index)."""

from __future__ import annotations

import numpy as np
import sapien

from datagen.families.grasp_attempts.execute import ExecutionParams, planned_poses
from datagen.families.grasp_attempts.grasps import GraspCandidate
from datagen.families.grasp_attempts.gripper_geometry import gripper_geometry
from datagen.families.grasp_attempts.planner import (
    make_planner,
    plan_straight,
    remove_obstacles,
    solve_ik,
    straight_path_free,
)
from datagen.families.grasp_tabletop.world import GraspScene


class ArmReach:
    """``reach(candidate)``: True when the arm reaches it in ``scene`` as it stands now, and
    lifts it."""

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
        return any(self._approach_and_lift(grasp, q) for q in self.transit_goals(pre))

    def transit_goals(self, pre: sapien.Pose) -> list[np.ndarray]:
        """The pre-grasp configurations execution's transit may end at (``plan_transit``)."""
        solutions = solve_ik(self.clear, pre, self.qpos)
        arm = self.clear.move_group_joint_indices
        for q in solutions:
            if straight_path_free(self.clear, self.qpos[arm], q[arm]):
                return [q]
        return solutions

    def _approach_and_lift(self, grasp: sapien.Pose, pre_q: np.ndarray) -> bool:
        approach = plan_straight(self.free, grasp, pre_q, self.time_step)
        if approach["status"] != "Success":
            return False
        at_grasp = pre_q.copy()
        at_grasp[self.free.move_group_joint_indices] = approach["position"][-1]
        lifted = sapien.Pose(np.add(grasp.p, [0.0, 0.0, self.params.lift_height]), grasp.q)
        return plan_straight(self.free, lifted, at_grasp, self.time_step)["status"] == "Success"
