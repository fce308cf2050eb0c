"""The jaw grippers of so100 and koch: width tables from FK, boxes in the grasp frame, and the
Franka hand unchanged by the generalisation (datagen.families.grasp_attempts.gripper_geometry)."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.families.grasp_attempts.gripper_geometry import gripper_geometry
from datagen.registries import ROBOTS

JAWS = {"so100": (0.095, 0.105), "koch": (0.063, 0.072)}  # FK: max width 0.1000, 0.0677 m


@pytest.mark.parametrize("name", sorted(JAWS))
def test_width_table_is_monotone_and_invertible(name):
    spec = ROBOTS[name].load()
    geometry = gripper_geometry(spec)
    low, high = JAWS[name]
    assert low < geometry.max_width < high
    assert 0 <= geometry.widths[0] < 0.004  # the jaws (nearly) touch when closed
    assert np.all(np.diff(geometry.widths) > 0)
    for q in np.linspace(*spec.gripper.finger_travel, 7):
        assert geometry.joint_for_width(geometry.width_for_joint(q)) == pytest.approx(q, abs=1e-6)


def _corners(box):
    transform, extents = box
    signs = np.array(np.meshgrid(*[[-0.5, 0.5]] * 3)).reshape(3, -1).T
    return (transform[:3, :3] @ (signs * extents).T).T + transform[:3, 3]


@pytest.mark.parametrize("name", sorted(JAWS))
def test_moving_jaw_opens_along_y_and_clears_the_fixed_jaw(name):
    geometry = gripper_geometry(ROBOTS[name].load())
    moving = len(geometry.fingers[0].pieces)
    narrow, wide = geometry.boxes(0.01)[:moving], geometry.boxes(geometry.max_width)[:moving]

    def tip(boxes):  # the box deepest along the approach
        return max(boxes, key=lambda b: b[0][2, 3])

    shift = _corners(tip(wide))[:, 1].min() - _corners(tip(narrow))[:, 1].min()
    assert shift > 0.2 * (geometry.max_width - 0.01)  # boxes around turned meshes: < half
    fixed = geometry.boxes(geometry.max_width)[moving : moving + len(geometry.fingers[1].pieces)]
    tip_fixed = max(fixed, key=lambda b: b[0][2, 3])  # the fixed jaw's box deepest along z
    tip_moving = max(wide, key=lambda b: b[0][2, 3])
    assert _corners(tip_moving)[:, 1].min() > _corners(tip_fixed)[:, 1].max()


def test_franka_hand_unchanged():
    geometry = gripper_geometry(ROBOTS["panda"].load())
    assert geometry.max_width == 0.08
    assert geometry.joint_for_width(0.05) == 0.025
    assert np.array_equal(geometry.tcp_in_grasp(0.05), np.eye(4))
    closed, opened = geometry.boxes(0.0), geometry.boxes(0.06)
    for index, side in ((0, 1.0), (len(geometry.fingers[0].boxes), -1.0)):
        moved = opened[index][0][:3, 3] - closed[index][0][:3, 3]
        np.testing.assert_allclose(moved, [0.0, side * 0.03, 0.0], atol=1e-12)


@pytest.mark.sim
@pytest.mark.parametrize("name", sorted(JAWS))
def test_sapien_loads_the_expected_joints(name):
    import sapien

    spec = ROBOTS[name].load()
    scene = sapien.Scene()
    loader = scene.create_urdf_loader()
    loader.fix_root_link = True
    robot = loader.load(str(spec.urdf_path()))
    assert [j.get_name() for j in robot.get_active_joints()] == list(spec.joint_names)


@pytest.mark.sim
@pytest.mark.parametrize("name", sorted(JAWS))
def test_ik_reaches_a_top_down_grasp(name):
    import mplib

    spec = ROBOTS[name].load()
    planner = mplib.Planner(
        urdf=str(spec.urdf_path()), srdf=str(spec.srdf_path()), move_group=spec.gripper.tcp_link
    )
    geometry = gripper_geometry(spec)
    grasp = np.eye(4)
    grasp[:3, :3] = np.diag([1.0, -1.0, -1.0])  # z down, y across
    grasp[:3, 3] = [0.25 * spec.reach / 0.45 if name == "koch" else 0.25, 0.0, 0.05]
    target = grasp @ geometry.tcp_in_grasp(0.03)
    from scipy.spatial.transform import Rotation

    quat = Rotation.from_matrix(target[:3, :3]).as_quat()  # x, y, z, w
    pose = np.r_[target[:3, 3], quat[3], quat[:3]]
    qpos = np.r_[spec.ready_pose, geometry.joint_for_width(0.03)]
    status, _ = planner.IK(pose, qpos, n_init_qpos=40)
    assert status == "Success"
