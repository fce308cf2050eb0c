"""Forward kinematics of the plain URDF reader (``Urdf.link_poses``) against SAPIEN's, for the
Panda at random joint positions within its limits."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.registries import ROBOTS
from datagen.robot_specs.urdf import read_urdf


@pytest.mark.sim
def test_link_poses_match_sapien_for_random_joint_positions():
    import sapien

    path = ROBOTS["panda"].load().urdf_path()
    urdf = read_urdf(path)
    scene = sapien.Scene()
    robot = scene.create_urdf_loader().load(str(path))
    joints = robot.get_active_joints()
    limits = np.array([j.limits[0] for j in joints], float)  # (dof, 2)
    rng = np.random.default_rng(0)
    for _ in range(5):
        qpos = rng.uniform(limits[:, 0], limits[:, 1])
        robot.set_qpos(qpos.astype(np.float32))
        poses = urdf.link_poses({j.name: float(q) for j, q in zip(joints, qpos, strict=True)})
        assert set(poses) == {link.name for link in robot.get_links()}
        for link in robot.get_links():
            expected = link.entity_pose.to_transformation_matrix()
            np.testing.assert_allclose(poses[link.name], expected, atol=1e-4, err_msg=link.name)
