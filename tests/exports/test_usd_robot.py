"""The robot in a grasp sample's USD stage (``datagen export --to usd``): every link an Xform at
SAPIEN's pose of it for the sample's joint positions, with the link's visual meshes where SAPIEN
draws them, and UsdPhysics joints making an articulation. Real samples rendered by SAPIEN
(``adversarial/grasp_dataset.py``), exported by the real CLI, the same URDF loaded by SAPIEN."""

from __future__ import annotations

import numpy as np
import pytest
from adversarial.grasp_dataset import grasp_samples, metadata, usd_dataset
from conftest import write_dataset  # tests/conftest.py: shards and a manifest, no MQTT

from datagen.registries import ROBOTS
from datagen.robot_specs.urdf import read_urdf

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    return usd_dataset(tmp_path_factory.mktemp("usd_robot") / "ds", write_dataset)


def _sapien_links(robot_meta) -> dict[str, tuple[np.ndarray, list[np.ndarray]]]:
    """Per link: (4, 4) world pose in SAPIEN and its render shapes' vertices in the link frame."""
    import sapien

    scene = sapien.Scene()
    robot = scene.create_urdf_loader().load(str(ROBOTS[robot_meta["name"]].load().urdf_path()))
    robot.set_root_pose(sapien.Pose(np.asarray(robot_meta["base_pose"]["matrix"], np.float32)))
    values = dict(zip(robot_meta["joint_names"], robot_meta["qpos"], strict=True))
    robot.set_qpos(np.array([values[j.name] for j in robot.get_active_joints()], np.float32))
    out = {}
    for link in robot.get_links():
        vertices = []
        body = link.entity.find_component_by_type(sapien.render.RenderBodyComponent)
        for shape in body.render_shapes if body is not None else []:
            local = shape.local_pose.to_transformation_matrix()
            for part in shape.parts:
                vertices.append(part.get_vertices() @ local[:3, :3].T + local[:3, 3])
        out[link.name] = (link.entity_pose.to_transformation_matrix(), vertices)
    return out


@pytest.mark.parametrize("index", [0, 1])
def test_the_stage_holds_the_robot_where_sapien_puts_it(exported, index):
    from pxr import Usd, UsdGeom, UsdPhysics

    from datagen.exports.usd_robot import link_paths
    from datagen.exports.usd_stage import validation_errors

    meta = metadata(grasp_samples()[index])
    stage = Usd.Stage.Open(str(exported / "usd" / f"{meta['key']}.usda"))
    assert validation_errors(stage) == []
    robot = stage.GetPrimAtPath("/World/Robot")
    assert robot.HasAPI(UsdPhysics.ArticulationRootAPI)
    assert list(robot.GetCustomDataByKey("datagen:qpos")) == meta["robot"]["qpos"]
    urdf = read_urdf(ROBOTS[meta["robot"]["name"]].load().urdf_path())
    paths = link_paths("/World/Robot", urdf)
    for name, (pose, sapien_vertices) in _sapien_links(meta["robot"]).items():
        link = stage.GetPrimAtPath(paths[name])
        world = np.asarray(UsdGeom.Xformable(link).ComputeLocalToWorldTransform(0)).T
        np.testing.assert_allclose(world[:3, 3], pose[:3, 3], atol=1e-4, err_msg=name)
        np.testing.assert_allclose(world[:3, :3], pose[:3, :3], atol=1e-4, err_msg=name)
        meshes = [UsdGeom.Mesh(c) for c in link.GetChildren() if c.IsA(UsdGeom.Mesh)]
        assert bool(meshes) == bool(urdf.links[name].visuals) == bool(sapien_vertices), name
        if meshes:  # decimated: the same extent as SAPIEN's visual within 5 mm, link frame
            ours = np.concatenate([np.asarray(m.GetPointsAttr().Get()) for m in meshes])
            theirs = np.concatenate(sapien_vertices)
            np.testing.assert_allclose(ours.min(0), theirs.min(0), atol=5e-3, err_msg=name)
            np.testing.assert_allclose(ours.max(0), theirs.max(0), atol=5e-3, err_msg=name)
            faces = sum(len(m.GetFaceVertexCountsAttr().Get()) for m in meshes)
            assert 0 < faces <= 2100, name
            assert all(m.GetDisplayColorAttr().Get() for m in meshes), name
    kinds = {"revolute": UsdPhysics.RevoluteJoint, "prismatic": UsdPhysics.PrismaticJoint}
    for joint in urdf.joints.values():
        prim = stage.GetPrimAtPath(f"/World/Robot/joints/{joint.name}")
        assert prim.IsA(kinds.get(joint.kind, UsdPhysics.FixedJoint)), joint.name
        usd_joint = UsdPhysics.Joint(prim)
        assert usd_joint.GetBody0Rel().GetTargets() == [paths[joint.parent]]
        assert usd_joint.GetBody1Rel().GetTargets() == [paths[joint.child]]
        if joint.kind == "revolute":
            upper = UsdPhysics.RevoluteJoint(prim).GetUpperLimitAttr().Get()
            assert upper == pytest.approx(np.degrees(joint.limits[1]), abs=1e-3)
    assert stage.GetPrimAtPath("/World/Robot/joints/root_joint").IsA(UsdPhysics.FixedJoint)
