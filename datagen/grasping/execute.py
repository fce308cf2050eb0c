"""Physical execution of one grasp attempt in a grasping scene, and its outcome label.

Sequence: open the gripper, plan a collision-free transit to the pre-grasp pose (backed off
along -approach), move straight to the grasp pose while watching contacts, close the fingers
with force-limited drives, lift straight up in world z, hold, then label the attempt. The robot
follows each planned trajectory one point per physics step through its joint drives, with
gravity compensation as in ManiSkill. Never raises for a bad candidate: planning failures are
labelled "unreachable".
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import sapien

from datagen.grasping import PANDA_MAX_WIDTH, GraspCandidate, GraspOutcome
from datagen.grasping.planner import make_planner, plan_straight, plan_transit, remove_obstacles
from datagen.robot_specs.panda import PANDA
from datagen.worlds.tabletop import GraspScene

N_ARM = PANDA.arm_joints


@dataclass(frozen=True)
class ExecutionParams:
    pregrasp_distance: float = 0.1  # metres back along -approach
    lift_height: float = 0.1  # metres, world z
    hold_time: float = 1.0  # simulated seconds after the lift
    open_margin: float = 0.01  # metres added to the candidate width (when not open_fully)
    open_fully: bool = True  # open to PANDA_MAX_WIDTH instead of width + margin
    arm_drive: tuple[float, float, float] = (1e3, 1e2, 100.0)  # stiffness, damping, force limit
    gripper_drive: tuple[float, float, float] = (1e3, 1e2, 100.0)  # N/m, N·s/m, N
    max_close_time: float = 1.0  # simulated seconds for opening or closing the fingers
    settle_time: float = 0.1  # simulated seconds after each motion
    collision_impulse: float = 0.005  # N·s per step; robot vs non-target contacts above it count
    lift_success_ratio: float = 0.5  # success needs rise >= ratio * lift_height
    closed_width: float = 0.002  # metres: fingers this close count as closed on nothing


class _Runner:
    """Steps the scene with joint targets and keeps the bookkeeping for the label."""

    def __init__(self, scene: GraspScene, target_id: int, params: ExecutionParams):
        self.scene, self.robot, self.params = scene.scene, scene.robot, params
        self.dt = self.scene.get_timestep()
        self.joints = self.robot.get_active_joints()
        links = {link.get_name(): link for link in self.robot.get_links()}
        self.tcp = links[PANDA.gripper.tcp_link]
        self.robot_ids = {link.entity.per_scene_id for link in links.values()}
        self.finger_ids = [links[name].entity.per_scene_id for name in PANDA.gripper.finger_links]
        self.target = next(o.entity for o in scene.objects if o.instance_id == target_id)
        self.steps = 0
        for i, joint in enumerate(self.joints):
            k, d, f = params.arm_drive if i < N_ARM else params.gripper_drive
            joint.set_drive_property(stiffness=k, damping=d, force_limit=f)
        self.arm_target = self.robot.get_qpos()[:N_ARM].astype(float)
        self.finger_target = float(self.robot.get_qpos()[N_ARM])

    def step(self, arm: np.ndarray, arm_vel: np.ndarray | None = None) -> float:
        """One physics step; returns the largest robot vs non-target contact impulse."""
        for i in range(N_ARM):
            self.joints[i].set_drive_target(float(arm[i]))
            self.joints[i].set_drive_velocity_target(0.0 if arm_vel is None else float(arm_vel[i]))
        for joint in self.joints[N_ARM:]:
            joint.set_drive_target(self.finger_target)
        self.robot.set_qf(
            self.robot.compute_passive_force(gravity=True, coriolis_and_centrifugal=True)
        )
        self.scene.step()
        self.steps += 1
        self.arm_target = np.asarray(arm, float)
        return self.collision_impulse()

    def hold(self, seconds: float) -> float:
        return max(
            [self.step(self.arm_target) for _ in range(round(seconds / self.dt))], default=0.0
        )

    def follow(self, trajectory: dict[str, Any]) -> float:
        worst = max(
            (
                self.step(q, v)
                for q, v in zip(trajectory["position"], trajectory["velocity"], strict=True)
            ),
            default=0.0,
        )
        return max(worst, self.hold(self.params.settle_time))

    def move_fingers(self, target: float) -> None:
        """Drives both fingers to ``target`` (metres each) until they stop."""
        self.finger_target = target
        still = 0
        for _ in range(round(self.params.max_close_time / self.dt)):
            self.step(self.arm_target)
            still = still + 1 if np.abs(self.robot.get_qvel()[N_ARM:]).max() < 1e-3 else 0
            if still >= 10:
                break

    def _contacts(self):
        for contact in self.scene.get_contacts():
            a, b = (body.entity.per_scene_id for body in contact.bodies)
            impulse = float(sum(np.linalg.norm(p.impulse) for p in contact.points))
            yield a, b, impulse

    def collision_impulse(self) -> float:
        target, worst = self.target.per_scene_id, 0.0
        for a, b, impulse in self._contacts():
            if (a in self.robot_ids) != (b in self.robot_ids) and target not in (a, b):
                worst = max(worst, impulse)
        return worst

    def held(self) -> bool:
        """The target touches both fingers."""
        target, touching = self.target.per_scene_id, set()
        for a, b, _ in self._contacts():
            if target in (a, b):
                touching |= {a, b} & set(self.finger_ids)
        return len(touching) == 2

    def width(self) -> float:
        return float(np.sum(self.robot.get_qpos()[N_ARM:]))

    def qpos(self) -> np.ndarray:
        return self.robot.get_qpos().astype(float)


def execute_grasp(
    scene: GraspScene, target_instance_id: int, candidate: GraspCandidate, params: ExecutionParams
) -> GraspOutcome:
    """Runs the attempt in ``scene`` (which it changes) and labels it."""
    run = _Runner(scene, target_instance_id, params)
    details: dict[str, Any] = {"params": asdict(params)}

    def outcome(success: bool, mode: str | None, rise: float = 0.0) -> GraspOutcome:
        details["steps"] = run.steps
        details["simulated_time"] = round(run.steps * run.dt, 6)
        return GraspOutcome(success, mode, round(rise, 6), round(run.width(), 6), details)

    width = (
        PANDA_MAX_WIDTH
        if params.open_fully
        else min(PANDA_MAX_WIDTH, candidate.width + params.open_margin)
    )
    run.move_fingers(width / 2)

    grasp = sapien.Pose(np.asarray(candidate.pose_world, float))
    pre = sapien.Pose(grasp.p - params.pregrasp_distance * candidate.approach, grasp.q)
    planner = make_planner(run.scene, run.robot, scene.objects)
    transit = plan_transit(planner, pre, run.qpos(), run.dt)
    details["transit"] = {"status": transit["status"], "method": transit["method"]}
    if transit["status"] != "Success":
        return outcome(False, "unreachable")
    remove_obstacles(planner)  # straight moves: physics decides about collisions
    # Plan the approach from the planned pre-grasp configuration, before moving, so that an
    # unreachable grasp pose costs no simulation.
    pre_q = run.qpos()
    pre_q[:N_ARM] = transit["position"][-1]
    approach = plan_straight(planner, grasp, pre_q, run.dt)
    details["approach"] = {"status": approach["status"]}
    if approach["status"] != "Success":
        return outcome(False, "unreachable")

    transit_impulse = run.follow(transit)
    approach_impulse = run.follow(approach)
    details["transit"]["max_contact_impulse"] = round(transit_impulse, 6)
    details["approach"]["max_contact_impulse"] = round(approach_impulse, 6)
    collided = max(transit_impulse, approach_impulse) > params.collision_impulse

    run.move_fingers(0.0)
    start_z = float(run.target.get_pose().p[2])
    held_after_close = run.held() and run.width() > params.closed_width
    details["close"] = {"width": round(run.width(), 6), "held": held_after_close}

    tcp = run.tcp.entity_pose
    lift = plan_straight(
        planner, sapien.Pose(np.add(tcp.p, [0, 0, params.lift_height]), tcp.q), run.qpos(), run.dt
    )
    details["lift"] = {"status": lift["status"]}
    if lift["status"] == "Success":
        run.follow(lift)
    run.hold(params.hold_time)
    rise = float(run.target.get_pose().p[2]) - start_z
    held_at_end = run.held() and run.width() > params.closed_width
    details["held_at_end"] = held_at_end

    if (
        lift["status"] == "Success"
        and held_at_end
        and rise >= params.lift_success_ratio * params.lift_height
    ):
        return outcome(True, None, rise)
    if collided:
        return outcome(False, "collision", rise)
    if lift["status"] != "Success":
        return outcome(False, "unreachable", rise)
    return outcome(False, "slipped" if held_after_close else "missed", rise)
