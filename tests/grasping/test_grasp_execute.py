"""Grasp execution on the real stack: SAPIEN physics, mplib planning, one box in the tray."""

from __future__ import annotations

import json

import numpy as np
import pytest
import sapien

from datagen.assets.tabletop_layout import TRAY_CENTRE, TRAY_FLOOR
from datagen.config import BuildConfig
from datagen.config.sections import ObjectsConfig
from datagen.families.grasp_attempts.execute import ExecutionParams, execute_grasp, plan_lift
from datagen.families.grasp_attempts.grasps import GraspCandidate
from datagen.families.grasp_attempts.planner import make_planner, plan_straight, remove_obstacles
from datagen.families.grasp_tabletop.world import GraspScene, build_scene

pytestmark = pytest.mark.sim

PARAMS = ExecutionParams()
CONFIG = BuildConfig(objects=ObjectsConfig(count=(1, 1), families=("box",), size=(0.05, 0.06)))


def box_scene() -> GraspScene:
    """One small box, its bounding box aligned with the world axes, settled on the tray floor."""
    scene = build_scene(CONFIG, seed=0, index=0)
    obj = scene.objects[0]
    lift = obj.geometry.obb_extents[2] / 2 + 0.002
    centre = sapien.Pose([TRAY_CENTRE[0], 0.0, TRAY_CENTRE[2] + TRAY_FLOOR + lift])
    obj.entity.set_pose(centre * sapien.Pose(obj.geometry.obb_transform).inv())
    for _ in range(200):
        scene.scene.step()
    return scene


def top_down(scene: GraspScene, offset=(0.0, 0.0, 0.0)) -> GraspCandidate:
    """Approach along world -z at the box centre (+ offset), closing across its narrow side."""
    obj = scene.objects[0]
    obb = (
        obj.entity.get_pose() * sapien.Pose(obj.geometry.obb_transform)
    ).to_transformation_matrix()
    narrow = int(np.argmin(obj.geometry.obb_extents[:2]))
    y, z = obb[:3, narrow], np.array([0.0, 0.0, -1.0])
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([np.cross(y, z), y, z])
    pose[:3, 3] = obb[:3, 3] + np.asarray(offset)
    return GraspCandidate(pose, float(obj.geometry.obb_extents[narrow]), "manual")


@pytest.fixture(scope="module")
def easy():
    scene = box_scene()
    return execute_grasp(scene, 1, top_down(scene), PARAMS)


def test_top_down_grasp_succeeds(easy):
    assert easy.success, easy.to_json()
    assert easy.failure_mode is None
    assert easy.lift_height == pytest.approx(PARAMS.lift_height, abs=0.02)
    assert 0.02 < easy.gripper_width < 0.06
    assert easy.details["transit"]["method"] == "joint_line"
    json.dumps(easy.to_json())


def test_closing_on_air_is_missed():
    scene = box_scene()
    out = execute_grasp(scene, 1, top_down(scene, (0.0, 0.15, 0.0)), PARAMS)
    assert (out.success, out.failure_mode) == (False, "missed"), out.to_json()
    assert out.gripper_width < 0.005
    assert abs(out.lift_height) < 0.01


def test_grasp_into_the_tray_floor_is_a_collision():
    scene = box_scene()
    out = execute_grasp(scene, 1, top_down(scene, (0.0, 0.15, -0.05)), PARAMS)
    assert (out.success, out.failure_mode) == (False, "collision"), out.to_json()
    assert out.details["approach"]["max_contact_impulse"] > PARAMS.collision_impulse


def test_far_pose_is_unreachable_without_raising():
    scene = box_scene()
    out = execute_grasp(scene, 1, top_down(scene, (1.5, 0.0, 0.0)), PARAMS)
    assert (out.success, out.failure_mode) == (False, "unreachable")
    assert out.details["transit"]["status"] != "Success"


def test_same_attempt_gives_the_same_outcome(easy):
    scene = box_scene()
    again = execute_grasp(scene, 1, top_down(scene), PARAMS)
    assert json.dumps(again.to_json(), sort_keys=True) == json.dumps(easy.to_json(), sort_keys=True)


def test_a_lift_the_screw_cannot_plan_from_the_hands_rotation_keeps_the_planned_one():
    """``plan_lift`` lifts from the hand's own rotation, and falls back to the planned grasp's
    when mplib's screw cannot plan from it (here the hand's pose turned half a turn about the
    approach: a screw of pi, which mplib refuses)."""
    scene = box_scene()
    planner = make_planner(scene.scene, scene.robot, scene.objects, scene.spec)
    remove_obstacles(planner)
    tcp_link = next(
        x for x in scene.robot.get_links() if x.get_name() == scene.spec.gripper.tcp_link
    )
    hand, qpos = tcp_link.entity_pose, np.asarray(scene.robot.get_qpos(), float)
    dt = scene.scene.get_timestep()

    held = plan_lift(planner, hand, hand, qpos, PARAMS.lift_height, dt)
    assert (held["status"], held["planned"]) == ("Success", False)

    turned = hand * sapien.Pose(q=[0.0, 0.0, 0.0, 1.0])  # half a turn about the TCP's z
    refused = plan_straight(
        planner, sapien.Pose(np.add(hand.p, [0, 0, PARAMS.lift_height]), turned.q), qpos, dt
    )
    assert refused["status"] != "Success"
    lifted = plan_lift(planner, turned, hand, qpos, PARAMS.lift_height, dt)
    assert (lifted["status"], lifted["planned"]) == ("Success", True)
    end = lifted["position"][-1]
    assert len(end) == len(planner.move_group_joint_indices)
