"""The plain URDF reader against SAPIEN's: forward kinematics (``Urdf.link_poses``) for the
Panda at random joint positions within its limits, and a link's principal inertia
(``Inertial.principal``) for an inertial frame rotated by rpy; the diagonalisation of a rotated
box's tensor; inertials and collision primitives as read."""

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


def test_principal_inertia_of_a_rotated_box():
    from scipy.spatial.transform import Rotation

    from datagen.robot_specs.urdf import Inertial

    mass, (a, b, c) = 2.0, (0.3, 0.1, 0.2)  # kg, metres
    moments = mass / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    box_axes = Rotation.from_euler("xyz", [0.3, -0.7, 1.1]).as_matrix()  # in the inertial frame
    origin = np.eye(4)
    origin[:3, :3] = Rotation.from_euler("xyz", [1.2, 0.4, -0.5]).as_matrix()  # URDF rpy
    origin[:3, 3] = (0.1, -0.2, 0.05)
    inertial = Inertial(mass, origin, box_axes @ np.diag(moments) @ box_axes.T)
    found, axes = inertial.principal()
    np.testing.assert_allclose(found, np.sort(moments), rtol=1e-12)
    np.testing.assert_allclose(axes.T @ axes, np.eye(3), atol=1e-12)
    assert np.linalg.det(axes) == pytest.approx(1.0)
    in_link = origin[:3, :3] @ box_axes  # the box's axes in the link frame, columns
    tensor = in_link @ np.diag(moments) @ in_link.T
    np.testing.assert_allclose(axes @ np.diag(found) @ axes.T, tensor, atol=1e-14)
    order = np.argsort(moments)  # each principal axis is the box's axis of that moment
    np.testing.assert_allclose(np.abs(axes.T @ in_link[:, order]), np.eye(3), atol=1e-12)
    assert all(axes[np.argmax(np.abs(axes[:, k])), k] > 0 for k in range(2))


URDF = """<robot name="two">
  <link name="base">
    <inertial>
      <origin xyz="0.1 -0.2 0.05" rpy="1.2 0.4 -0.5"/>
      <mass value="2.0"/>
      <inertia ixx="0.01" ixy="0.002" ixz="-0.001" iyy="0.02" iyz="0.003" izz="0.015"/>
    </inertial>
    <collision>
      <origin xyz="0 0 0.1" rpy="0 0 0.3"/><geometry><box size="0.2 0.1 0.05"/></geometry>
    </collision>
    <collision><geometry><cylinder radius="0.04" length="0.3"/></geometry></collision>
    <collision><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <link name="tip">
    <inertial><mass value="0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


def test_inertials_and_collisions_are_read(tmp_path):
    (tmp_path / "two.urdf").write_text(URDF)
    urdf = read_urdf(tmp_path / "two.urdf")
    base = urdf.links["base"]
    assert [g.kind for g in base.collisions] == ["box", "cylinder", "sphere"]
    assert base.collisions[0].size == (0.2, 0.1, 0.05) and base.collisions[1].size == (0.04, 0.3)
    assert base.inertial.mass == 2.0
    np.testing.assert_allclose(base.inertial.origin[:3, 3], (0.1, -0.2, 0.05))
    assert base.inertial.inertia[0, 1] == base.inertial.inertia[1, 0] == 0.002
    assert base.inertial.inertia[1, 2] == 0.003 and base.inertial.inertia[2, 2] == 0.015
    assert urdf.links["tip"].inertial.mass == 0.0


@pytest.mark.sim
def test_principal_inertia_matches_sapien_for_a_rotated_inertial(tmp_path):
    import sapien
    from scipy.spatial.transform import Rotation

    (tmp_path / "two.urdf").write_text(URDF)
    moments, axes = read_urdf(tmp_path / "two.urdf").links["base"].inertial.principal()
    scene = sapien.Scene()  # alive while its robot is read
    base = scene.create_urdf_loader().load(str(tmp_path / "two.urdf")).get_links()[0]
    np.testing.assert_allclose(moments, np.sort(base.inertia), rtol=1e-5)
    w, x, y, z = base.cmass_local_pose.q
    theirs = Rotation.from_quat([x, y, z, w]).as_matrix()
    tensor = theirs @ np.diag(base.inertia) @ theirs.T
    np.testing.assert_allclose(axes @ np.diag(moments) @ axes.T, tensor, atol=1e-7)
    np.testing.assert_allclose(base.cmass_local_pose.p, (0.1, -0.2, 0.05), atol=1e-6)


@pytest.mark.parametrize("name", ["panda", "iiwa14", "xarm7", "so100", "koch"])
def test_every_built_in_description_passes_the_user_urdf_checks(tmp_path, monkeypatch, name):
    from datagen.robot_specs.urdf_files import check_files

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))  # where the composed ones are written
    path = ROBOTS[name].load().urdf_path()
    read_urdf.cache_clear()
    assert read_urdf(path).links
    check_files(path)


def test_a_chain_of_20000_links_is_read_and_posed_in_linear_time(tmp_path):
    """Four times the links takes about four times the CPU time, whatever the machine's speed
    and load (a scan of every joint per link took sixteen times as long: minutes at 20,000)."""
    import time

    def read_and_pose(count: int, copy: int) -> float:
        links = "".join(f'<link name="l{i}"/>' for i in range(count + 1))
        joints = "".join(
            f'<joint name="j{i}" type="fixed"><parent link="l{i}"/><child link="l{i + 1}"/>'
            '<origin xyz="0 0 0.001"/></joint>'
            for i in range(count)
        )
        path = tmp_path / f"long{count}-{copy}.urdf"  # read_urdf keeps what it read by path
        path.write_text(f'<robot name="long">{links}{joints}</robot>')
        started = time.process_time()
        urdf = read_urdf(path)
        poses = urdf.link_poses()
        assert len(urdf.subtree("l0")) == count + 1
        assert poses[f"l{count}"][2, 3] == pytest.approx(count * 0.001)
        return time.process_time() - started

    quarter = min(read_and_pose(5_000, copy) for copy in range(2))
    whole = min(read_and_pose(20_000, copy) for copy in range(2))  # the least disturbed of two
    assert whole < 10 * quarter, (whole, quarter)  # linear: 4 (6 measured); quadratic: 16
