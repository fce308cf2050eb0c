"""The composed arm + Franka hand descriptions load in SAPIEN and plan with mplib."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.registries import ROBOTS
from datagen.robot_specs import RobotSpec

pytestmark = pytest.mark.sim

ARMS = ("iiwa14", "xarm7")
WORLD_BASE = np.array([-0.62, 0.0, 0.75])  # metres, the worlds' robot base
TRAY_TCP = np.array([0.08, 0.0, 0.9, 0.0, 1.0, 0.0, 0.0])  # above the tray centre, z down (wxyz)
HAND_TO_TCP = 0.1034  # metres, panda_hand_tcp_joint


@pytest.fixture(scope="module", autouse=True)
def _cache(tmp_path_factory):
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("XDG_CACHE_HOME", str(tmp_path_factory.mktemp("cache")))
        yield


@pytest.fixture(scope="module", params=ARMS)
def spec(request) -> RobotSpec:
    return ROBOTS[request.param].load()


@pytest.fixture(scope="module")
def robot(spec):
    import sapien

    scene = sapien.Scene()
    robot = scene.create_urdf_loader().load(str(spec.urdf_path()))
    assert robot is not None, spec.urdf_path()
    yield robot  # the scene must outlive the articulation
    del scene


def test_the_composed_file_is_the_same_on_every_call(spec):
    first = spec.urdf_path()
    assert spec.urdf_path() == first
    assert first.read_bytes() == spec.urdf_path().read_bytes()
    assert spec.srdf_path() == spec.srdf_path()


def test_joints_links_and_masses(spec, robot):
    active = [joint.get_name() for joint in robot.get_active_joints()]
    assert active == [*spec.arm_joints, *spec.gripper.finger_joints]
    lower, upper = robot.get_qlimits()[: len(spec.arm_joints)].T
    assert np.all((lower <= spec.ready_pose) & (spec.ready_pose <= upper))
    links = {link.get_name(): link for link in robot.get_links()}
    assert set(spec.gripper.links) <= set(links)
    for name, link in links.items():
        if link.get_collision_shapes():
            assert link.get_mass() > 0, name
    kinematics = robot.create_pinocchio_model()
    kinematics.compute_forward_kinematics(np.array([*spec.ready_pose, 0.0, 0.0]))
    order = [link.get_name() for link in robot.get_links()]
    hand, tcp = (kinematics.get_link_pose(order.index(name)) for name in spec.gripper.links[:2])
    assert np.linalg.norm(tcp.p - hand.p) == pytest.approx(HAND_TO_TCP, abs=1e-5)


def test_mplib_reaches_above_the_tray(spec, robot):
    import mplib

    planner = mplib.Planner(
        urdf=str(spec.urdf_path()),
        srdf=str(spec.srdf_path()),
        user_link_names=[link.get_name() for link in robot.get_links()],
        user_joint_names=[joint.get_name() for joint in robot.get_active_joints()],
        move_group=spec.gripper.tcp_link,
    )
    planner.set_base_pose(np.concatenate([WORLD_BASE + spec.mount, [1.0, 0.0, 0.0, 0.0]]))
    start = np.array([*spec.ready_pose, 0.04, 0.04])
    assert not planner.check_for_self_collision(qpos=start)
    goal = planner.transform_goal_to_wrt_base(TRAY_TCP)
    status, _ = planner.IK(goal, start, n_init_qpos=40)
    assert status == "Success", status
