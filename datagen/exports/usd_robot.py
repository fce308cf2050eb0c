"""The robot of a grasp sample in its USD stage: ``/World/Robot`` (an Xform at the base pose,
``UsdPhysics.ArticulationRootAPI``; customData ``datagen:description``, ``datagen:qpos`` and
``datagen:joint_names``) holds one Xform per URDF link at its pose for the sample's joint
positions (forward kinematics of :meth:`datagen.robot_specs.urdf.Urdf.link_poses`, in the
robot's root frame) with ``UsdPhysics.RigidBodyAPI`` and, where the URDF gives an inertial,
``UsdPhysics.MassAPI``. Under it ``visual_<i>_<j>``: the link's visual geometry as Meshes in the
link frame (visual origin and mesh scale applied), one per material of the mesh file with its
base colour as ``displayColor``; and ``collision_<i>``: its collision geometry, not rendered
(purpose guide), with ``UsdPhysics.CollisionAPI`` (a mesh one Mesh with a convex hull
approximation, primitives as Cube, Cylinder or Sphere). Mesh files are decimated to about
:data:`MAX_FACES_PER_LINK` triangles per link, visuals and collisions each (open3d quadric
decimation, deterministic), once per process. ``/World/Robot/joints/<joint>``: a UsdPhysics
Revolute, Prismatic or Fixed joint between the two link prims (limits in degrees or metres, the
joint's position in customData ``datagen:position``; each joint the sample sets has a
``UsdPhysics.DriveAPI`` holding it there), and ``root_joint`` fixing the root link to the world.
The stage's kilogramsPerUnit is 1. The physics schemas and their units:
:mod:`datagen.exports.usd_robot_physics`. Everything is inline: the stage refers to no other file
(``datagen replay`` refuses those).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from pxr import Gf, Tf, UsdGeom, UsdPhysics, Vt
from scipy.spatial.transform import Rotation

from datagen.assets.mesh_simplify import decimated, face_budgets
from datagen.exports.usd_robot_physics import (
    define_drive,
    define_mass,
    define_primitive_collider,
    make_mesh_collider,
    quat,
)
from datagen.robot_specs.urdf import Geometry, Joint, Link, Urdf, read_urdf

MAX_FACES_PER_LINK = 2000
POINT_DECIMALS = 5  # points rounded to 10 micrometres: shorter text, far below the mesh error
DEFAULT_COLOUR = (0.7, 0.7, 0.7)  # linear RGB of a mesh file (or primitive) without materials
_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


@dataclass(frozen=True)
class Part:
    """A triangle mesh of one colour: vertices (n, 3) metres, faces (m, 3), colour linear RGB."""

    vertices: np.ndarray
    faces: np.ndarray
    colour: tuple[float, float, float]


def _matrix(m: np.ndarray) -> Gf.Matrix4d:
    return Gf.Matrix4d(np.asarray(m, float).T.tolist())  # USD uses row vectors


def _colour(mesh: trimesh.Trimesh) -> tuple[float, float, float]:
    material = getattr(mesh.visual, "material", None)
    rgba = getattr(material if material is not None else mesh.visual, "main_color", None)
    if rgba is None:
        return DEFAULT_COLOUR
    r, g, b = (float(c) / 255 for c in np.asarray(rgba)[:3])
    return (r, g, b)


@functools.lru_cache(maxsize=64)
def mesh_file_parts(path: Path, max_faces: int = MAX_FACES_PER_LINK) -> tuple[Part, ...]:
    """The visual mesh file at ``path`` (its own frame, unscaled), one Part per material,
    decimated to about ``max_faces`` triangles in all (shared out by face count)."""
    try:
        loaded = trimesh.load(path)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: cannot read this robot mesh ({exc})") from None
    found = loaded.dump() if isinstance(loaded, trimesh.Scene) else [loaded]
    meshes: list[trimesh.Trimesh] = [
        m for m in found if isinstance(m, trimesh.Trimesh) and len(m.faces)
    ]
    budgets = face_budgets([len(m.faces) for m in meshes], max_faces)
    return tuple(
        Part(*decimated(mesh.vertices, mesh.faces, budget), _colour(mesh))
        for mesh, budget in zip(meshes, budgets, strict=True)
    )


def _primitive(geometry: Geometry) -> trimesh.Trimesh:
    if geometry.kind == "box":
        return trimesh.creation.box(extents=geometry.size)
    if geometry.kind == "cylinder":
        return trimesh.creation.cylinder(radius=geometry.size[0], height=geometry.size[1])
    return trimesh.creation.icosphere(subdivisions=2, radius=geometry.size[0])


def geometry_parts(geometry: Geometry, max_faces: int) -> list[Part]:
    """A visual element as Parts in its link's frame (origin and scale applied)."""
    if geometry.kind != "mesh" or geometry.mesh is None:
        tri = _primitive(geometry).apply_transform(geometry.origin)
        return [Part(np.asarray(tri.vertices), np.asarray(tri.faces), DEFAULT_COLOUR)]
    to_link = geometry.origin @ np.diag([*geometry.scale, 1.0])
    out = []
    for part in mesh_file_parts(geometry.mesh, max_faces):
        vertices = trimesh.transform_points(part.vertices, to_link)
        faces = part.faces if np.linalg.det(to_link[:3, :3]) > 0 else part.faces[:, ::-1]
        out.append(Part(vertices, faces, part.colour))
    return out


def _mesh(stage, path: str, part: Part) -> UsdGeom.Mesh:
    usd_mesh = UsdGeom.Mesh.Define(stage, path)
    points = np.round(part.vertices, POINT_DECIMALS).astype(np.float32)
    usd_mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    usd_mesh.CreateFaceVertexCountsAttr(
        Vt.IntArray.FromNumpy(np.full(len(part.faces), 3, np.int32))
    )
    usd_mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(part.faces.astype(np.int32).ravel()))
    usd_mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    lo, hi = points.min(axis=0), points.max(axis=0)
    usd_mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))]))
    usd_mesh.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*part.colour)]))
    return usd_mesh


def _axis_frame(axis: np.ndarray) -> tuple[str, np.ndarray]:
    """(USD axis token, (3, 3) rotation of the joint frame) putting the URDF axis on a USD axis."""
    for token, unit in _AXES.items():
        if np.allclose(axis, unit):
            return token, np.eye(3)
    rotation, _ = Rotation.align_vectors([axis], [_AXES["X"]])
    return "X", rotation.as_matrix()


def _joint(
    stage, path: str, joint: Joint, links: dict[str, str], position: float, driven: bool
) -> None:
    if joint.kind in ("revolute", "continuous"):
        usd_joint = UsdPhysics.RevoluteJoint.Define(stage, path)
    elif joint.kind == "prismatic":
        usd_joint = UsdPhysics.PrismaticJoint.Define(stage, path)
    else:  # fixed; floating and planar joints are not in datagen's robots
        usd_joint = UsdPhysics.FixedJoint.Define(stage, path)
    usd_joint.CreateBody0Rel().SetTargets([links[joint.parent]])
    usd_joint.CreateBody1Rel().SetTargets([links[joint.child]])
    # a fixed joint's frame needs no axis (koch's URDF gives one of length 0)
    token, frame = ("X", np.eye(3)) if joint.kind == "fixed" else _axis_frame(joint.axis)
    usd_joint.CreateLocalPos0Attr(Gf.Vec3f(*map(float, joint.origin[:3, 3])))
    usd_joint.CreateLocalRot0Attr(quat(joint.origin[:3, :3] @ frame))
    usd_joint.CreateLocalPos1Attr(Gf.Vec3f(0.0, 0.0, 0.0))
    usd_joint.CreateLocalRot1Attr(quat(frame))
    prim = usd_joint.GetPrim()
    if isinstance(usd_joint, UsdPhysics.FixedJoint):
        return
    usd_joint.CreateAxisAttr(token)
    if joint.limits is not None:
        scale = 180 / np.pi if joint.kind == "revolute" else 1.0  # USD: degrees, URDF: radians
        usd_joint.CreateLowerLimitAttr(float(joint.limits[0] * scale))
        usd_joint.CreateUpperLimitAttr(float(joint.limits[1] * scale))
    prim.SetCustomDataByKey("datagen:position", float(position))  # radians or metres
    if driven:
        define_drive(prim, joint, position)
    if joint.mimic is not None:
        prim.SetCustomDataByKey(
            "datagen:mimic", f"{joint.mimic[0]} * {joint.mimic[1]:g} + {joint.mimic[2]:g}"
        )


def _position(joint: Joint, values: dict[str, float]) -> float:
    """The joint's value (radians or metres); a mimic joint not in ``values`` follows its leader."""
    if joint.name not in values and joint.mimic is not None:
        leader, multiplier, offset = joint.mimic
        return multiplier * values.get(leader, 0.0) + offset
    return values.get(joint.name, 0.0)


def _collisions(stage, path: str, link: Link) -> None:
    """``collision_<i>``: the link's collision elements (usd_robot_physics's docstring)."""
    budget = MAX_FACES_PER_LINK // max(len(link.collisions), 1)
    for i, geometry in enumerate(link.collisions):
        if geometry.kind != "mesh":
            define_primitive_collider(stage, f"{path}/collision_{i}", geometry)
            continue
        parts = geometry_parts(geometry, budget)
        if not parts:
            continue
        offsets = np.cumsum([0] + [len(p.vertices) for p in parts])[:-1]
        merged = Part(
            np.concatenate([p.vertices for p in parts]),
            np.concatenate([p.faces + o for p, o in zip(parts, offsets, strict=True)]),
            DEFAULT_COLOUR,
        )
        make_mesh_collider(_mesh(stage, f"{path}/collision_{i}", merged).GetPrim())


def link_paths(root: str, urdf: Urdf) -> dict[str, str]:
    """The prim path of every link: ``<root>/<link name as a USD identifier>``."""
    return {name: f"{root}/{Tf.MakeValidIdentifier(name)}" for name in urdf.links}


def robot_urdf(robot: dict[str, Any]) -> Path:
    """The URDF of the sample's robot (``robot.name`` in :data:`datagen.registries.ROBOTS`)."""
    from datagen.registries import ROBOTS

    return ROBOTS[robot["name"]].load().urdf_path()


def define_robot(stage, path: str, robot: dict[str, Any], key: str) -> UsdGeom.Xform:
    """The sample's ``robot`` metadata (name, description, base_pose, joint_names, qpos) as the
    articulated robot at ``path`` (module docstring)."""
    xform = UsdGeom.Xform.Define(stage, path)
    xform.AddTransformOp().Set(_matrix(np.asarray(robot["base_pose"]["matrix"])))
    prim = xform.GetPrim()
    prim.SetCustomDataByKey("datagen:description", robot["description"])
    prim.SetCustomDataByKey("datagen:qpos", Vt.DoubleArray(robot["qpos"]))
    prim.SetCustomDataByKey("datagen:joint_names", Vt.StringArray(robot["joint_names"]))
    if len(robot["joint_names"]) != len(robot["qpos"]):
        raise ValueError(f"sample {key}: robot.joint_names and robot.qpos differ in length")
    UsdPhysics.ArticulationRootAPI.Apply(prim)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)  # the links' masses are in kg
    urdf = read_urdf(robot_urdf(robot))
    values = dict(zip(robot["joint_names"], map(float, robot["qpos"]), strict=True))
    poses, paths = urdf.link_poses(values), link_paths(path, urdf)
    for name, link in urdf.links.items():
        link_xform = UsdGeom.Xform.Define(stage, paths[name])
        link_xform.AddTransformOp().Set(_matrix(poses[name]))
        UsdPhysics.RigidBodyAPI.Apply(link_xform.GetPrim())
        define_mass(link_xform.GetPrim(), link.inertial)
        budget = MAX_FACES_PER_LINK // max(len(link.visuals), 1)
        for i, visual in enumerate(link.visuals):
            for j, part in enumerate(geometry_parts(visual, budget)):
                _mesh(stage, f"{paths[name]}/visual_{i}_{j}", part)
        _collisions(stage, paths[name], link)
    UsdGeom.Scope.Define(stage, f"{path}/joints")
    root_joint = UsdPhysics.FixedJoint.Define(stage, f"{path}/joints/root_joint")
    root_joint.CreateBody1Rel().SetTargets([paths[urdf.root]])  # body0 unset: the world
    base = np.asarray(robot["base_pose"]["matrix"], float)
    root_joint.CreateLocalPos0Attr(Gf.Vec3f(*map(float, base[:3, 3])))
    root_joint.CreateLocalRot0Attr(quat(base[:3, :3]))
    for joint in urdf.joints.values():
        joint_path = f"{path}/joints/{Tf.MakeValidIdentifier(joint.name)}"
        driven = joint.name in values
        _joint(stage, joint_path, joint, paths, _position(joint, values), driven)
    return xform
