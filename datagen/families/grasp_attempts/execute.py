"""Physical execution of one grasp attempt in a grasping scene, and its outcome label.

Sequence: open the gripper, plan a collision-free transit to the pre-grasp pose (backed off
along -approach), move straight to the grasp pose while watching contacts, close the fingers
with force-limited drives, lift straight up in world z, hold, then label the attempt. The robot
follows each planned trajectory one point per physics step through its joint drives, with
gravity compensation as in ManiSkill. Never raises for a bad candidate: planning failures are
labelled "unreachable". An attempt in which an object moved faster than the hand could push it
is labelled "disturbed" (:mod:`datagen.families.grasp_attempts.disturbance`); the grasp frame at closure is
kept beside the planned one (:mod:`datagen.families.grasp_attempts.executed`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import mplib
import numpy as np
import sapien

from datagen.families.grasp_attempts.disturbance import DisturbanceWatch
from datagen.families.grasp_attempts.executed import executed_grasp
from datagen.families.grasp_attempts.grasps import GraspCandidate, GraspOutcome
from datagen.families.grasp_attempts.gripper_geometry import GripperGeometry, gripper_geometry
from datagen.families.grasp_attempts.planner import (
    make_planner,
    plan_straight,
    plan_transit,
    remove_obstacles,
)
from datagen.families.grasp_attempts.recording import Recorder, StepState
from datagen.families.grasp_tabletop.world import GraspScene
from datagen.robot_specs import RobotSpec

RigidBody = sapien.physx.PhysxRigidDynamicComponent


@dataclass(frozen=True)
class ExecutionParams:
    pregrasp_distance: float = 0.1  # metres back along -approach
    lift_height: float = 0.1  # metres, world z
    hold_time: float = 1.0  # simulated seconds after the lift
    open_margin: float = 0.01  # metres added to the candidate width (when not open_fully)
    open_fully: bool = True  # open to the gripper's max width instead of width + margin
    arm_drive: tuple[float, float, float] = (1e3, 1e2, 100.0)  # stiffness, damping, force limit
    gripper_drive: tuple[float, float, float] = (1e3, 1e2, 100.0)  # N/m, N·s/m, N
    max_close_time: float = 1.0  # simulated seconds for opening or closing the fingers
    settle_time: float = 0.1  # simulated seconds after each motion
    collision_impulse: float = 0.005  # N·s per step; robot vs non-target contacts above it count
    lift_success_ratio: float = 0.5  # success needs rise >= ratio * lift_height
    closed_width: float = 0.002  # metres beyond fully closed: closer counts as closed on nothing


class _Runner:
    """Steps the scene with joint targets and keeps the bookkeeping for the label."""

    def __init__(
        self,
        scene: GraspScene,
        target_id: int,
        params: ExecutionParams,
        recorder: Recorder | None = None,
    ):
        self.scene, self.robot, self.params = scene.scene, scene.robot, params
        self.recorder, self.impulse = recorder, 0.0  # impulse: the last step's
        self.dt = self.scene.get_timestep()
        spec = scene.spec
        joints = {joint.get_name(): joint for joint in self.robot.get_active_joints()}
        order = [joint.get_name() for joint in self.robot.get_active_joints()]
        self.arm = [joints[name] for name in spec.arm_joints]
        self.fingers = [joints[name] for name in spec.gripper.finger_joints]
        self.arm_index = [order.index(name) for name in spec.arm_joints]  # into get_qpos()
        self.finger_index = [order.index(name) for name in spec.gripper.finger_joints]
        self.joint_index = [order.index(name) for name in spec.joint_names]
        links = {link.get_name(): link for link in self.robot.get_links()}
        self.tcp = links[spec.gripper.tcp_link]
        self.robot_ids = {link.entity.per_scene_id for link in links.values()}
        self.finger_ids = [links[name].entity.per_scene_id for name in spec.gripper.finger_links]
        self.geometry, self.jaw = gripper_geometry(spec), spec.gripper.jaw
        self.closed = float(self.geometry.widths[0])  # metres between the pads, fully closed
        self.target = next(o.entity for o in scene.objects if o.instance_id == target_id)
        self.steps, self.phase = 0, ""
        self._body_ids: dict[Any, int] = {}  # a contact's body component -> its per-scene id
        bodies = [
            (o.instance_id, o.entity.find_component_by_type(RigidBody)) for o in scene.objects
        ]
        self.watch = DisturbanceWatch(self.robot, bodies, self.dt)
        self._set_up(spec, links)
        self.arm_target = self.robot.get_qpos()[self.arm_index].astype(float)
        self.finger_target = float(self.robot.get_qpos()[self.finger_index[0]])

    def _set_up(self, spec: RobotSpec, links: dict[str, Any]) -> None:
        """The drives, armature and gripper friction the attempt runs with."""
        for joint in self.arm:
            joint.set_drive_property(*self.params.arm_drive)
        for joint in self.fingers:
            joint.set_drive_property(*(spec.gripper.drive or self.params.gripper_drive))
        if spec.armature:
            for joint in self.arm + self.fingers:
                joint.set_armature([spec.armature])
        if spec.gripper.friction is not None:  # set here: the scene settled with the default
            friction = spec.gripper.friction
            material = sapien.physx.PhysxMaterial(friction, friction, 0.0)
            for name in spec.gripper.links:
                for shape in links[name].get_collision_shapes():
                    shape.set_physical_material(material)

    def step(self, arm: np.ndarray, arm_vel: np.ndarray | None = None) -> float:
        """One physics step; returns the largest robot vs non-target contact impulse."""
        for i, joint in enumerate(self.arm):
            joint.set_drive_target(float(arm[i]))
            joint.set_drive_velocity_target(0.0 if arm_vel is None else float(arm_vel[i]))
        for joint in self.fingers:
            joint.set_drive_target(self.finger_target)
        if self.recorder is not None:
            self._record(arm, arm_vel)
        self.robot.set_qf(
            self.robot.compute_passive_force(gravity=True, coriolis_and_centrifugal=True)
        )
        self.scene.step()
        self.steps += 1
        self.watch.observe(self.steps, self.phase)
        self.arm_target = np.asarray(arm, float)
        self.impulse = self.collision_impulse()
        return self.impulse

    def _record(self, arm: np.ndarray, arm_vel: np.ndarray | None) -> None:
        velocity = np.zeros(len(self.arm)) if arm_vel is None else np.asarray(arm_vel, float)
        command = np.concatenate([np.asarray(arm, float), velocity, [self.finger_target]])
        recorder = self.recorder
        assert recorder is not None  # recorded only when a recorder is set
        if recorder.command(self.steps, command):
            recorder.state(self.steps, self.observe())

    def observe(self) -> StepState:
        """The state the recorder keeps (reads only: recording leaves the physics alone)."""
        left, right = self.finger_contacts()
        tcp, target = self.tcp.entity_pose, self.target.get_pose()
        return StepState(
            qpos=self.robot.get_qpos()[self.joint_index],
            qvel=self.robot.get_qvel()[self.joint_index],
            gripper_opening=self.width(),
            tcp_pose=np.concatenate([tcp.p, tcp.q]),
            target_pose=np.concatenate([target.p, target.q]),
            contact=(float(left), float(right), self.impulse),
        )

    def begin_phase(self, name: str) -> None:
        self.phase = name
        if self.recorder is not None:
            self.recorder.begin_phase(name, self.steps)

    def finish(self) -> None:
        if self.recorder is not None:
            self.recorder.finish(self.steps, self.observe())

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

    def move_fingers(self, width: float) -> None:
        """Drives the fingers to open ``width`` metres apart until they stop."""
        self.finger_target = self.finger_value(width)
        still = 0
        for _ in range(round(self.params.max_close_time / self.dt)):
            self.step(self.arm_target)
            still = (
                still + 1 if np.abs(self.robot.get_qvel()[self.finger_index]).max() < 1e-3 else 0
            )
            if still >= 10:
                break

    def _contact_pairs(self):
        """(contact, id of one body, id of the other) of every contact this step. A body's id
        is looked up once per attempt: SAPIEN hands out the same component object every step."""
        ids = self._body_ids
        for contact in self.scene.get_contacts():
            a, b = contact.bodies
            if a not in ids:
                ids[a] = a.entity.per_scene_id
            if b not in ids:
                ids[b] = b.entity.per_scene_id
            yield contact, ids[a], ids[b]

    def collision_impulse(self) -> float:
        """N·s: the largest summed impulse of a contact between the robot and anything but the
        target. Only those contacts' points are summed: every step's hot path, and the objects'
        contacts with each other and the tray outnumber them."""
        target, robot, worst = self.target.per_scene_id, self.robot_ids, 0.0
        for contact, a, b in self._contact_pairs():
            if (a in robot) != (b in robot) and target not in (a, b):
                worst = max(worst, float(sum(np.linalg.norm(p.impulse) for p in contact.points)))
        return worst

    def finger_contacts(self) -> tuple[bool, bool]:
        """Whether the target touches the first (left) and the second (right) finger."""
        target, touching = self.target.per_scene_id, set()
        for _, a, b in self._contact_pairs():
            if target in (a, b):
                touching |= {a, b} & set(self.finger_ids)
        return self.finger_ids[0] in touching, self.finger_ids[1] in touching

    def held(self) -> bool:
        """The target touches both fingers."""
        return all(self.finger_contacts())

    def finger_value(self, width: float) -> float:
        """The finger joints' target for an opening of ``width`` metres: half of it for each
        of two prismatic fingers, a jaw's angle from its URDF (gripper_geometry)."""
        return self.geometry.joint_for_width(width) if self.jaw else width / 2

    def width(self) -> float:
        """Metres between the finger pads now."""
        q = self.robot.get_qpos()[self.finger_index]
        return self.geometry.width_for_joint(float(q[0])) if self.jaw else float(np.sum(q))

    def qpos(self) -> np.ndarray:
        return self.robot.get_qpos().astype(float)


def planned_poses(
    candidate: GraspCandidate, geometry: GripperGeometry, params: ExecutionParams
) -> tuple[float, np.ndarray, sapien.Pose, sapien.Pose]:
    """(opening width in metres, the TCP link's (4, 4) pose in the grasp frame at that width,
    pre-grasp pose, grasp pose): where the planner sends the TCP link for ``candidate`` (the
    candidate is the grasp frame, between the pads)."""
    max_width = geometry.max_width
    width = max_width if params.open_fully else min(max_width, candidate.width + params.open_margin)
    tcp_in_grasp = geometry.tcp_in_grasp(width)
    tcp_target = np.asarray(candidate.pose_world, float)
    if not np.array_equal(tcp_in_grasp, np.eye(4)):  # a jaw gripper's TCP is off-centre
        tcp_target = tcp_target @ tcp_in_grasp
    grasp = sapien.Pose(tcp_target)
    pre = sapien.Pose(grasp.p - params.pregrasp_distance * candidate.approach, grasp.q)
    return width, tcp_in_grasp, pre, grasp


def plan_lift(
    planner: mplib.Planner,
    tcp: sapien.Pose,
    grasp: sapien.Pose,
    qpos: np.ndarray,
    lift_height: float,
    time_step: float,
) -> dict[str, Any]:
    """A straight lift of the TCP by ``lift_height`` metres in world z from ``tcp``, keeping its
    rotation; else (``planned`` true) the planned grasp's. mplib's screw failed from the
    closed hand's own rotation, a few milliradians off the one its forward kinematics gives,
    where the planned rotation lifted the same hand (4 of the panda's 11 unreachable attempts on
    held-out objects, docs/campaigns.md)."""
    up = np.add(tcp.p, [0.0, 0.0, lift_height])
    lift = plan_straight(planner, sapien.Pose(up, tcp.q), qpos, time_step)
    if lift["status"] == "Success":
        return lift | {"planned": False}
    lifted = sapien.Pose(up, grasp.q)
    return plan_straight(planner, lifted, qpos, time_step) | {"planned": True}


def execute_grasp(
    scene: GraspScene,
    target_instance_id: int,
    candidate: GraspCandidate,
    params: ExecutionParams,
    recorder: Recorder | None = None,
) -> GraspOutcome:
    """Runs the attempt in ``scene`` (which it changes) and labels it; ``recorder``, if given,
    records it step by step (phases: ``datagen.dataset.trajectory.PHASES``)."""
    run = _Runner(scene, target_instance_id, params, recorder)
    details: dict[str, Any] = {"params": asdict(params)}
    executed: dict[str, Any] | None = None  # set once the fingers have closed
    if scene.spec.gripper.drive is not None:  # the robot's own, in place of the default
        details["params"]["gripper_drive"] = list(scene.spec.gripper.drive)

    def outcome(success: bool, mode: str | None, rise: float = 0.0) -> GraspOutcome:
        run.finish()
        details["steps"] = run.steps
        details["simulated_time"] = round(run.steps * run.dt, 6)
        details["disturbance"] = run.watch.to_json()
        if run.watch.disturbed:  # the label the attempt would have had, kept beside
            details["disturbance"]["label"] = {"success": success, "failure_mode": mode}
            success, mode = False, "disturbed"
        width = round(run.width(), 6)
        return GraspOutcome(success, mode, round(rise, 6), width, details, executed)

    width, tcp_in_grasp, pre, grasp = planned_poses(candidate, run.geometry, params)
    run.begin_phase("open")
    run.move_fingers(width)
    planner = make_planner(run.scene, run.robot, scene.objects, scene.spec)
    transit = plan_transit(planner, pre, run.qpos(), run.dt)
    details["transit"] = {"status": transit["status"], "method": transit["method"]}
    if transit["status"] != "Success":
        return outcome(False, "unreachable")
    remove_obstacles(planner)  # straight moves: physics decides about collisions
    # Plan the approach from the planned pre-grasp configuration, before moving, so that an
    # unreachable grasp pose costs no simulation.
    pre_q = run.qpos()
    pre_q[run.arm_index] = transit["position"][-1]
    approach = plan_straight(planner, grasp, pre_q, run.dt)
    details["approach"] = {"status": approach["status"]}
    if approach["status"] != "Success":
        return outcome(False, "unreachable")

    run.begin_phase("transit")
    transit_impulse = run.follow(transit)
    run.begin_phase("approach")
    approach_impulse = run.follow(approach)
    details["transit"]["max_contact_impulse"] = round(transit_impulse, 6)
    details["approach"]["max_contact_impulse"] = round(approach_impulse, 6)
    collided = max(transit_impulse, approach_impulse) > params.collision_impulse

    run.begin_phase("close")
    run.move_fingers(0.0)  # closed
    executed = executed_grasp(
        np.asarray(candidate.pose_world, float),
        run.tcp.entity_pose.to_transformation_matrix(),
        tcp_in_grasp,
        run.robot.get_qpos()[run.joint_index],
        run.steps * run.dt,
    )
    run.begin_phase("lift")
    start_z = float(run.target.get_pose().p[2])
    held_after_close = run.held() and run.width() > run.closed + params.closed_width
    details["close"] = {"width": round(run.width(), 6), "held": held_after_close}

    lift = plan_lift(planner, run.tcp.entity_pose, grasp, run.qpos(), params.lift_height, run.dt)
    details["lift"] = {"status": lift["status"]} | (
        {"rotation": "planned"} if lift["planned"] else {}
    )
    if lift["status"] == "Success":
        run.follow(lift)
    run.begin_phase("hold")
    run.hold(params.hold_time)
    rise = float(run.target.get_pose().p[2]) - start_z
    held_at_end = run.held() and run.width() > run.closed + params.closed_width
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
