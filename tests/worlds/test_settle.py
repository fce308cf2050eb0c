"""Settling ends when the objects rest (``physics.settle_velocity``), at most after
``physics.settle_time``; the robot holds its sampled joints meanwhile (datagen/worlds/settle.py)."""

from __future__ import annotations

import numpy as np
import pytest
import sapien

from datagen.families.grasp_tabletop.world import load_arm
from datagen.registries import ROBOTS
from datagen.scene_values.arm import ArmPose
from datagen.worlds.realise import apply_robot
from datagen.worlds.settle import CHECK_EVERY, REST_CHECKS, at_rest, settle, surface_speeds

HALF = 0.03  # metres, half the box's edge


def test_at_rest_needs_consecutive_slow_checks():
    assert not at_rest([], 0.01)
    assert not at_rest([0.005], 0.01)
    assert at_rest([0.5, 0.005, 0.009], 0.01)
    assert not at_rest([0.005, 0.02], 0.01)
    assert not at_rest([0.005, 0.01], 0.01)


def _box_scene(height: float):
    scene = sapien.Scene()
    scene.set_timestep(0.005)
    scene.add_ground(0.0)
    builder = scene.create_actor_builder()
    builder.add_box_collision(half_size=[HALF] * 3)
    box = builder.build(name="box")
    box.set_pose(sapien.Pose([0, 0, height]))
    return scene, box.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)


@pytest.mark.sim
def test_a_resting_box_settles_after_the_rest_checks():
    scene, body = _box_scene(HALF)
    assert settle(scene, [body], [HALF], None, 300, 0.01) == CHECK_EVERY * REST_CHECKS


@pytest.mark.sim
def test_a_dropped_box_settles_early_and_slow():
    scene, body = _box_scene(0.3)
    steps = settle(scene, [body], [HALF], None, 300, 0.01)
    assert CHECK_EVERY * REST_CHECKS < steps < 300
    assert steps % CHECK_EVERY == 0
    assert surface_speeds([body], [HALF]).max() < 0.01
    assert body.entity_pose.p[2] == pytest.approx(HALF, abs=2e-3)


@pytest.mark.sim
def test_zero_settle_velocity_runs_the_full_time():
    scene, body = _box_scene(HALF)
    assert settle(scene, [body], [HALF], None, 300, 0.0) == 300


@pytest.mark.sim
def test_the_robot_keeps_its_joints_while_objects_settle_and_wakes_after():
    scene, body = _box_scene(0.3)
    robot = load_arm(scene, ROBOTS["panda"].load())
    robot.set_root_pose(sapien.Pose([-0.6, 0, 0]))  # clear of the falling box
    qpos = [0.0, -0.95, 0.0, -2.75, 0.0, 1.95, 0.785, 0.02, 0.02]
    apply_robot(ArmPose(tuple(qpos)), robot, ROBOTS["panda"].load().joint_names)
    settle(scene, [body], [HALF], robot, 300, 0.0)
    assert np.abs(robot.get_qpos() - np.asarray(qpos, np.float32)).max() < 1e-5
    assert not robot.get_links()[0].sleeping
    awake = sapien.Scene()
    awake.set_timestep(0.005)
    sagging = load_arm(awake, ROBOTS["panda"].load())
    sagging.set_root_pose(sapien.Pose([-0.6, 0, 0]))
    apply_robot(ArmPose(tuple(qpos)), sagging, ROBOTS["panda"].load().joint_names)
    for _ in range(300):
        awake.step()
    assert np.abs(sagging.get_qpos() - np.asarray(qpos, np.float32)).max() > 1e-3


@pytest.mark.sim
def test_a_value_type_without_a_sapien_realiser_is_an_error():
    from datagen.scene_values.arm import WristLook
    from datagen.worlds.realise import realise

    with pytest.raises(TypeError, match="no SAPIEN realiser for scene values of type WristLook"):
        realise(WristLook((0, 0, 1), (0, 0, 0), (1, 0, 0)), sapien.Scene())
