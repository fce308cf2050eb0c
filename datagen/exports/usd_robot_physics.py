"""The physics of the robot's links and joints in a grasp sample's USD stage
(:mod:`datagen.exports.usd_robot` writes the prims, this module their UsdPhysics schemas).

* Mass: ``UsdPhysics.MassAPI`` on a link with a URDF ``<inertial>`` of positive mass: ``mass``
  (kg), ``centerOfMass`` (the inertial origin's translation, link frame, metres),
  ``diagonalInertia`` (principal moments, ascending, kg m^2) and ``principalAxes`` (the principal
  frame's orientation in the link frame, w >= 0: a rotation R whose columns are the principal
  axes, so that the link-frame tensor is ``R diag(diagonalInertia) R^T``; the URDF tensor is
  first rotated by the inertial origin's rpy; :meth:`datagen.robot_specs.urdf.Inertial.principal`).
* Collision: one prim per URDF ``<collision>`` under the link, ``collision_<i>``, with
  ``UsdPhysics.CollisionAPI`` and purpose ``guide`` (not rendered): a box is a Cube of size 1
  scaled to its sizes, a cylinder a Cylinder along z, a sphere a Sphere, each at the collision
  origin; a mesh is one Mesh (all its parts, decimated like the visuals, in the link frame)
  with ``UsdPhysics.MeshCollisionAPI`` approximation ``convexHull``, as SAPIEN (PhysX) cooks it.
* Drive: ``UsdPhysics.DriveAPI`` (``angular`` or ``linear``, type force) on each joint the sample
  sets, its target the sample's position (degrees or metres), stiffness and damping those of
  the simulator's drive holding the robot there (:data:`datagen.robot_specs.HOLD_STIFFNESS`, ``HOLD_DAMPING``
  in SI per radian, written per degree for angular drives as UsdPhysics counts them).
"""

from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdPhysics
from scipy.spatial.transform import Rotation

from datagen.robot_specs import HOLD_DAMPING, HOLD_STIFFNESS
from datagen.robot_specs.urdf import Geometry, Inertial, Joint


def _vec3f(values) -> Gf.Vec3f:
    return Gf.Vec3f(*(float(v) for v in values))


def quat(rotation: np.ndarray) -> Gf.Quatf:
    """A (3, 3) rotation as USD's (w, x, y, z) quaternion, w >= 0."""
    x, y, z, w = Rotation.from_matrix(rotation).as_quat(canonical=True)
    return Gf.Quatf(float(w), float(x), float(y), float(z))


def define_mass(prim: Usd.Prim, inertial: Inertial | None) -> None:
    """The link's MassAPI (module docstring); nothing without an inertial of positive mass."""
    if inertial is None or inertial.mass <= 0:
        return
    moments, axes = inertial.principal()
    mass_api = UsdPhysics.MassAPI.Apply(prim)
    mass_api.CreateMassAttr(float(inertial.mass))
    mass_api.CreateCenterOfMassAttr(_vec3f(inertial.origin[:3, 3]))
    mass_api.CreateDiagonalInertiaAttr(_vec3f(moments))
    mass_api.CreatePrincipalAxesAttr(quat(axes))


def _collider(prim: Usd.Prim) -> None:
    UsdPhysics.CollisionAPI.Apply(prim)
    UsdGeom.Imageable(prim).CreatePurposeAttr(UsdGeom.Tokens.guide)


def define_primitive_collider(stage: Usd.Stage, path: str, geometry: Geometry) -> Usd.Prim:
    """A box, cylinder or sphere ``<collision>`` as a posed Cube, Cylinder or Sphere collider."""
    size = [float(s) for s in geometry.size]
    if geometry.kind == "box":
        shape = UsdGeom.Cube.Define(stage, path)
        shape.CreateSizeAttr(1.0)
        half = (0.5, 0.5, 0.5)
    elif geometry.kind == "cylinder":
        shape = UsdGeom.Cylinder.Define(stage, path)
        shape.CreateRadiusAttr(size[0])
        shape.CreateHeightAttr(size[1])
        shape.CreateAxisAttr(UsdGeom.Tokens.z)
        half = (size[0], size[0], size[1] / 2)
    elif geometry.kind == "sphere":
        shape = UsdGeom.Sphere.Define(stage, path)
        shape.CreateRadiusAttr(size[0])
        half = (size[0],) * 3
    else:
        raise ValueError(f"{path}: a {geometry.kind} collision is not a primitive")
    shape.CreateExtentAttr([_vec3f(-h for h in half), _vec3f(half)])  # its own frame
    shape.AddTransformOp().Set(Gf.Matrix4d(np.asarray(geometry.origin, float).T.tolist()))
    if geometry.kind == "box":
        shape.AddScaleOp().Set(_vec3f(size))
    _collider(shape.GetPrim())
    return shape.GetPrim()


def make_mesh_collider(prim: Usd.Prim) -> None:
    """A Mesh (in its link's frame) as a convex hull collider."""
    _collider(prim)
    UsdPhysics.MeshCollisionAPI.Apply(prim).CreateApproximationAttr(UsdPhysics.Tokens.convexHull)


def define_drive(prim: Usd.Prim, joint: Joint, position: float) -> None:
    """A PD drive holding a revolute or prismatic joint at ``position`` (radians or metres)."""
    angular = joint.kind in ("revolute", "continuous")
    if not angular and joint.kind != "prismatic":
        return
    per_unit = np.pi / 180 if angular else 1.0  # UsdPhysics: per degree for angular drives
    drive = UsdPhysics.DriveAPI.Apply(prim, "angular" if angular else "linear")
    drive.CreateTypeAttr(UsdPhysics.Tokens.force)
    drive.CreateTargetPositionAttr(float(np.degrees(position) if angular else position))
    drive.CreateStiffnessAttr(HOLD_STIFFNESS * per_unit)
    drive.CreateDampingAttr(HOLD_DAMPING * per_unit)
