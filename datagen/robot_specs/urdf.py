"""A URDF read as plain values (xml.etree, no simulator): links with their visual and collision
geometry and mass properties, joints with origins, axes, limits and mimics, and forward
kinematics.

Used where datagen needs a robot's geometry without a physics scene: the gripper's collision
volume for the grasp samplers (:mod:`datagen.families.grasp_attempts.gripper_geometry`) and the robot's
meshes in USD stages. Transforms are 4x4 numpy arrays, metres and radians.
"""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from datagen.robot_specs.urdf_values import check_values
from datagen.robot_specs.urdf_xml import parse_urdf_xml


@dataclass(frozen=True)
class Geometry:
    """A visual or collision element: ``kind`` is box, cylinder, sphere or mesh."""

    kind: str
    origin: np.ndarray  # (4, 4) in its link's frame
    size: tuple[float, ...] = ()  # box: full sizes; cylinder: (radius, length); sphere: (radius,)
    mesh: Path | None = None  # resolved against the URDF's folder
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class Inertial:
    """A link's mass properties: ``mass`` kg, ``origin`` (4, 4) the inertial frame in the link's
    (its translation the centre of mass), ``inertia`` (3, 3) kg m^2 about the centre of mass,
    in the inertial frame."""

    mass: float
    origin: np.ndarray
    inertia: np.ndarray

    def principal(self) -> tuple[np.ndarray, np.ndarray]:
        """(3,) principal moments, ascending, kg m^2, and (3, 3) a rotation whose columns are
        the principal axes in the link's frame: ``axes @ diag(moments) @ axes.T`` is the
        tensor in the link's frame. Each axis has its largest component positive, the third
        flipped if needed to make a right-handed frame (eigenvectors are defined up to sign)."""
        rotation = self.origin[:3, :3]
        tensor = rotation @ self.inertia @ rotation.T
        moments, axes = np.linalg.eigh((tensor + tensor.T) / 2)
        signs = np.sign(axes[np.argmax(np.abs(axes), axis=0), range(3)])
        axes = axes * signs
        if np.linalg.det(axes) < 0:
            axes[:, 2] *= -1
        return moments, axes


@dataclass(frozen=True)
class Link:
    name: str
    visuals: tuple[Geometry, ...]
    collisions: tuple[Geometry, ...]
    inertial: Inertial | None = None  # None: no <inertial> (or one without <mass>)


@dataclass(frozen=True)
class Joint:
    name: str
    kind: str  # revolute, continuous, prismatic, fixed, ...
    parent: str
    child: str
    origin: np.ndarray  # (4, 4) child's frame at zero in the parent's
    axis: np.ndarray  # (3,) unit, in the joint frame
    limits: tuple[float, float] | None
    mimic: tuple[str, float, float] | None = None  # (joint, multiplier, offset)

    def motion(self, value: float) -> np.ndarray:
        """(4, 4) the joint's motion at ``value`` (radians or metres)."""
        out = np.eye(4)
        if self.kind in ("revolute", "continuous"):
            from scipy.spatial.transform import Rotation  # 0.25 s: only when a joint moves

            out[:3, :3] = Rotation.from_rotvec(self.axis * value).as_matrix()
        elif self.kind == "prismatic":
            out[:3, 3] = self.axis * value
        return out


@dataclass(frozen=True)
class Urdf:
    name: str
    links: dict[str, Link]
    joints: dict[str, Joint]  # by name, in file order
    root: str

    def child_joints(self, link: str) -> list[Joint]:
        return self._children.get(link, [])

    @functools.cached_property
    def _children(self) -> dict[str, list[Joint]]:
        """The joints below each link, in file order (one pass: a scan per link was quadratic)."""
        children: dict[str, list[Joint]] = {}
        for joint in self.joints.values():
            children.setdefault(joint.parent, []).append(joint)
        return children

    def link_poses(self, values: dict[str, float] | None = None) -> dict[str, np.ndarray]:
        """(4, 4) every link's frame in the root link's, joints at ``values`` (by name; mimic
        joints follow their leader; missing joints at 0)."""
        values = dict(values or {})
        for joint in self.joints.values():
            if joint.mimic and joint.name not in values:
                leader, multiplier, offset = joint.mimic
                values[joint.name] = multiplier * values.get(leader, 0.0) + offset
        poses = {self.root: np.eye(4)}
        stack = [self.root]
        while stack:
            parent = stack.pop()
            for joint in self.child_joints(parent):
                motion = joint.motion(values.get(joint.name, 0.0))
                poses[joint.child] = poses[parent] @ joint.origin @ motion
                stack.append(joint.child)
        return poses

    def subtree(self, link: str) -> list[str]:
        """``link`` and every link below it."""
        out, stack = [], [link]
        while stack:
            current = stack.pop()
            out.append(current)
            stack.extend(j.child for j in self.child_joints(current))
        return out


def _floats(text: str | None, default: tuple[float, ...]) -> tuple[float, ...]:
    return default if text is None else tuple(float(v) for v in text.split())


def _origin(element: ET.Element | None) -> np.ndarray:
    out = np.eye(4)
    if element is None:
        return out
    from scipy.spatial.transform import Rotation

    out[:3, :3] = Rotation.from_euler("xyz", _floats(element.get("rpy"), (0, 0, 0))).as_matrix()
    out[:3, 3] = _floats(element.get("xyz"), (0, 0, 0))
    return out


def _geometry(element: ET.Element, folder: Path) -> Geometry | None:
    shape = element.find("geometry")
    if shape is None or len(shape) == 0:
        return None
    first, origin = shape[0], _origin(element.find("origin"))
    if first.tag == "box":
        return Geometry("box", origin, _floats(first.get("size"), (0, 0, 0)))
    if first.tag == "cylinder":
        size = (float(first.get("radius", 0)), float(first.get("length", 0)))
        return Geometry("cylinder", origin, size)
    if first.tag == "sphere":
        return Geometry("sphere", origin, (float(first.get("radius", 0)),))
    if first.tag == "mesh":
        filename = first.get("filename", "").removeprefix("file://")
        scale = _floats(first.get("scale"), (1.0, 1.0, 1.0))
        return Geometry("mesh", origin, mesh=folder / filename, scale=scale)  # type: ignore[arg-type]
    return None


def _inertial(element: ET.Element | None) -> Inertial | None:
    mass = None if element is None else element.find("mass")
    if element is None or mass is None:
        return None
    inertia = element.find("inertia")
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    xx, xy, xz, yy, yz, zz = (float(_attr(inertia, k) or 0) for k in keys)
    tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    return Inertial(float(mass.get("value", 0)), _origin(element.find("origin")), tensor)


def _joint(element: ET.Element) -> Joint:
    limit, mimic = element.find("limit"), element.find("mimic")
    axis = np.asarray(_floats(_attr(element.find("axis"), "xyz"), (1, 0, 0)), float)
    limits = None
    if limit is not None and element.get("type") in ("revolute", "prismatic"):
        limits = (float(limit.get("lower", 0)), float(limit.get("upper", 0)))
    return Joint(
        name=element.get("name", ""),
        kind=element.get("type", "fixed"),
        parent=_attr(element.find("parent"), "link") or "",
        child=_attr(element.find("child"), "link") or "",
        origin=_origin(element.find("origin")),
        axis=axis / (np.linalg.norm(axis) or 1.0),
        limits=limits,
        mimic=None
        if mimic is None
        else (
            mimic.get("joint", ""),
            float(mimic.get("multiplier", 1)),
            float(mimic.get("offset", 0)),
        ),
    )


def _attr(element: ET.Element | None, key: str) -> str | None:
    return None if element is None else element.get(key)


@functools.lru_cache(maxsize=16)
def read_urdf(path: Path) -> Urdf:
    """The URDF at ``path``, read within bounds and checked (every number finite and in range,
    one tree of links: :mod:`datagen.robot_specs.urdf_values`); a ConfigError naming the file,
    the element and the value when it is not usable."""
    root = parse_urdf_xml(path)
    root_link = check_values(root, path)
    folder = path.parent
    links = {}
    for element in root.findall("link"):
        visuals = [_geometry(v, folder) for v in element.findall("visual")]
        collisions = [_geometry(c, folder) for c in element.findall("collision")]
        name = element.get("name", "")
        inertial = _inertial(element.find("inertial"))
        links[name] = Link(
            name, tuple(g for g in visuals if g), tuple(g for g in collisions if g), inertial
        )
    joints = {j.name: j for j in (_joint(e) for e in root.findall("joint"))}
    return Urdf(root.get("name", path.stem), links, joints, root_link)
