"""The robot in a grasp sample's USD stage (``datagen export --to usd``): every link an Xform at
SAPIEN's pose of it for the sample's joint positions, with the link's visual meshes where SAPIEN
draws them, and UsdPhysics joints making an articulation; each link's mass, centre of mass and
principal inertia as SAPIEN has them, its collision shapes as unrendered colliders matching
SAPIEN's, and drives holding the sampled joints. Real samples rendered by SAPIEN
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
        visuals = [c for c in link.GetChildren() if c.GetName().startswith("visual_")]
        assert all(c.IsA(UsdGeom.Mesh) for c in visuals), name
        meshes = [UsdGeom.Mesh(c) for c in visuals]
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


def _sapien_robot(name: str):
    import sapien

    scene = sapien.Scene()
    return scene, scene.create_urdf_loader().load(str(ROBOTS[name].load().urdf_path()))


def _stage_and_urdf(exported, index: int = 0):
    from pxr import Usd

    from datagen.exports.usd_robot import link_paths

    meta = metadata(grasp_samples()[index])
    stage = Usd.Stage.Open(str(exported / "usd" / f"{meta['key']}.usda"))
    urdf = read_urdf(ROBOTS[meta["robot"]["name"]].load().urdf_path())
    return meta, stage, urdf, link_paths("/World/Robot", urdf)


def _tensor(moments, rotation: np.ndarray) -> np.ndarray:
    return rotation @ np.diag(np.asarray(moments, float)) @ rotation.T


def test_every_link_has_the_mass_properties_sapien_gives_it(exported):
    from pxr import UsdPhysics
    from scipy.spatial.transform import Rotation

    meta, stage, urdf, paths = _stage_and_urdf(exported)
    _, robot = _sapien_robot(meta["robot"]["name"])
    massive = 0
    for link in robot.get_links():
        prim, inertial = stage.GetPrimAtPath(paths[link.name]), urdf.links[link.name].inertial
        assert prim.HasAPI(UsdPhysics.MassAPI) == (inertial is not None), link.name
        if inertial is None:
            continue
        massive += 1
        mass_api = UsdPhysics.MassAPI(prim)
        mass = mass_api.GetMassAttr().Get()
        assert mass == pytest.approx(inertial.mass, rel=1e-6), link.name
        assert mass == pytest.approx(link.mass, rel=1e-4), link.name
        com = np.asarray(mass_api.GetCenterOfMassAttr().Get())
        np.testing.assert_allclose(com, link.cmass_local_pose.p, atol=1e-5, err_msg=link.name)
        moments = np.asarray(mass_api.GetDiagonalInertiaAttr().Get(), float)
        np.testing.assert_allclose(moments, np.sort(link.inertia), rtol=1e-6, err_msg=link.name)
        q = mass_api.GetPrincipalAxesAttr().Get()  # (w, x, y, z): principal axes in the link
        ours = Rotation.from_quat([*q.GetImaginary(), q.GetReal()]).as_matrix()
        w, x, y, z = link.cmass_local_pose.q
        theirs = Rotation.from_quat([x, y, z, w]).as_matrix()
        np.testing.assert_allclose(
            _tensor(moments, ours), _tensor(link.inertia, theirs), atol=1e-5 * moments.max()
        )
    assert massive >= 10  # the Panda's arm links, hand and fingers


def _usd_bounds(stage, prim, link_prim) -> np.ndarray:
    """(2, 3) the prim's bounds in its link's frame (guide purpose included)."""
    from pxr import Usd, UsdGeom

    cache = UsdGeom.BBoxCache(
        Usd.TimeCode.Default(), [UsdGeom.Tokens.default_, UsdGeom.Tokens.guide]
    )
    box = cache.ComputeRelativeBound(prim, link_prim).ComputeAlignedRange()
    return np.array([box.GetMin(), box.GetMax()])


def _sapien_bounds(shape) -> np.ndarray:
    """(2, 3) a SAPIEN collision shape's bounds in its link's frame."""
    if hasattr(shape, "half_size"):
        corners = np.array(np.meshgrid(*[[-h, h] for h in shape.half_size])).reshape(3, -1).T
    else:
        corners = shape.get_vertices() * shape.scale
    local = shape.local_pose.to_transformation_matrix()
    points = corners @ local[:3, :3].T + local[:3, 3]
    return np.array([points.min(0), points.max(0)])


def test_every_link_has_its_collision_shapes_as_unrendered_colliders(exported):
    from pxr import UsdGeom, UsdPhysics

    meta, stage, urdf, paths = _stage_and_urdf(exported)
    _, robot = _sapien_robot(meta["robot"]["name"])
    colliders = 0
    for link in robot.get_links():
        link_prim, geometries = (
            stage.GetPrimAtPath(paths[link.name]),
            urdf.links[link.name].collisions,
        )
        prims = [c for c in link_prim.GetChildren() if c.HasAPI(UsdPhysics.CollisionAPI)]
        assert [p.GetName() for p in prims] == [f"collision_{i}" for i in range(len(geometries))]
        assert len(prims) == len(link.collision_shapes), link.name
        for prim, geometry, shape in zip(prims, geometries, link.collision_shapes, strict=True):
            colliders += 1
            assert UsdGeom.Imageable(prim).ComputePurpose() == UsdGeom.Tokens.guide
            if geometry.kind == "mesh":
                assert prim.IsA(UsdGeom.Mesh)
                approximation = UsdPhysics.MeshCollisionAPI(prim).GetApproximationAttr().Get()
                assert approximation == UsdPhysics.Tokens.convexHull
            else:
                assert prim.IsA(UsdGeom.Gprim) and not prim.IsA(UsdGeom.Mesh)
            np.testing.assert_allclose(
                _usd_bounds(stage, prim, link_prim),
                _sapien_bounds(shape),
                atol=2e-3,
                err_msg=link.name,
            )
    assert colliders >= 17  # nine meshes, four boxes per finger


def test_the_sampled_joints_have_drives_holding_them_at_the_sample(exported):
    from pxr import UsdPhysics

    meta, stage, urdf, _ = _stage_and_urdf(exported)
    values = dict(zip(meta["robot"]["joint_names"], meta["robot"]["qpos"], strict=True))
    for joint in urdf.joints.values():
        prim = stage.GetPrimAtPath(f"/World/Robot/joints/{joint.name}")
        kind = "angular" if joint.kind == "revolute" else "linear"
        assert prim.HasAPI(UsdPhysics.DriveAPI, kind) == (joint.name in values), joint.name
        if joint.name in values:
            target = UsdPhysics.DriveAPI(prim, kind).GetTargetPositionAttr().Get()
            value = np.degrees(values[joint.name]) if kind == "angular" else values[joint.name]
            assert target == pytest.approx(value, abs=1e-4), joint.name
            assert UsdPhysics.DriveAPI(prim, kind).GetStiffnessAttr().Get() > 0
