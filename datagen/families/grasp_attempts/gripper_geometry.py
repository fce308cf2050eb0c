"""A robot's two-finger gripper as oriented boxes, derived from the collision shapes of its
description (:mod:`datagen.robot_specs.urdf`), its opening as a function of the finger joint,
and the samplers' collision check.

Every collision shape of a finger link (and the links below it, the other finger's excepted)
becomes the box around it: a URDF box exactly, a mesh, cylinder or sphere its bounding box in
its own frame. The hand (the hand link's subtree without the fingers) is the bounding box of
its shapes. The arm behind the hand is not modelled: reachability belongs to the motion planner.

The width is the distance along the closing axis (y of the TCP frame) between the origins of
the two pad links (:attr:`GripperSpec.pads`), tabulated from forward kinematics over the finger
travel: for the Franka hand exactly twice the finger joint. Prismatic fingers slide along
their joint axes; a jaw gripper's moving jaw turns with its joint, placed by forward
kinematics at the angle of the width. Boxes are given in the **grasp frame**: the TCP frame
moved along y to midway between the pads at that width (z, the approach, and x as the TCP's);
for a symmetric gripper it is the TCP frame. The TCP link is at ``tcp_in_grasp(width)`` in it.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from datagen.convex import BodySet, ConvexBody
from datagen.robot_specs import GripperSpec, RobotSpec
from datagen.robot_specs.urdf import Geometry, Joint, Urdf, read_urdf

Box = tuple[np.ndarray, np.ndarray]  # (4, 4) transform, (3,) full extents
JAW_SAMPLES = 201  # joint values the width of a jaw is tabulated at
DECIMALS = 12  # widths and centres rounded to 1e-12 m: a symmetric gripper's come out exact


@dataclass(frozen=True)
class Finger:
    """Prismatic: ``boxes`` in the TCP frame, closed, sliding along ``direction`` by half the
    width's change. Revolute (``joint`` set): ``boxes`` in the moving link's frame, which is at
    ``frame @ joint.motion(q)`` in the TCP frame. Neither: ``boxes`` in the TCP frame, fixed."""

    boxes: tuple[Box, ...]
    direction: np.ndarray | None = None  # (3,) unit, in the TCP frame
    joint: Joint | None = None
    frame: np.ndarray | None = None  # (4, 4) the joint's frame at zero, in the TCP frame
    # a jaw gripper's finger: each collision shape's points (in ``boxes``' frame), boxed
    # axis-aligned in the TCP frame at each opening (a box turned with the jaw would reach
    # into the space between the pads)
    pieces: tuple[np.ndarray, ...] = ()


@dataclass(frozen=True)
class GripperGeometry:
    fingers: tuple[Finger, Finger]
    hand_boxes: tuple[Box, ...]  # in the TCP frame
    joint_values: np.ndarray  # (n,) the finger joint, closed .. open (metres each or radians)
    widths: np.ndarray  # (n,) metres between the pads, increasing
    centres: np.ndarray  # (n,) metres, y of the pads' midpoint in the TCP frame

    @property
    def max_width(self) -> float:
        """Metres between the finger pads, fully open."""
        return float(self.widths[-1])

    def joint_for_width(self, width: float) -> float:
        """The finger joint value (each finger's, metres or radians) opening to ``width``,
        clipped to the travel."""
        return float(np.interp(width, self.widths, self.joint_values))

    def width_for_joint(self, q: float) -> float:
        return float(np.interp(q, self.joint_values, self.widths))

    def tcp_in_grasp(self, width: float) -> np.ndarray:
        """(4, 4) the TCP link's pose in the grasp frame at ``width``: the planner's target
        is ``grasp_pose @ tcp_in_grasp(width)``."""
        out = np.eye(4)
        centre = float(np.interp(width, self.widths, self.centres))
        if centre != 0.0:
            out[1, 3] = -centre
        return out

    def tip_reach(self, width: float) -> float:
        """Metres from the grasp frame's origin to the fingertips along the approach (+z)."""
        return max(
            float(transform[2, 3] + np.abs(transform[2, :3]) @ extents / 2)
            for transform, extents in self._finger_boxes(width)
        )

    def _finger_boxes(self, width: float) -> list[Box]:
        out: list[Box] = []
        for finger in self.fingers:
            if finger.pieces:
                link = np.eye(4)
                if finger.joint is not None:
                    assert finger.frame is not None
                    link = finger.frame @ finger.joint.motion(self.joint_for_width(width))
                out.extend(_aligned_box(link, points) for points in finger.pieces)
                continue
            for transform, extents in finger.boxes:
                moved = transform.copy()
                if finger.direction is not None:
                    moved[:3, 3] += finger.direction * (width - self.widths[0]) / 2
                out.append((moved, extents))
        return out

    def boxes(self, width: float, approach_distance: float = 0.0) -> list[Box]:
        """Every box in the grasp frame with the fingers opened to ``width``; with
        ``approach_distance`` > 0 the volume each sweeps on the approach from that distance
        back along -z: a box along the grasp frame's axes stretched back, one turned about them
        (the Franka finger's slanted block) first boxed along the axes. (Stretching a turned
        box along its own axes would sweep its long side across the gap between the fingers:
        a 30° block reached 2.5 cm inwards over 0.1 m.)"""
        out = self._finger_boxes(width) + list(self.hand_boxes)
        centre = float(np.interp(width, self.widths, self.centres))
        swept = []
        for transform, extents in out:
            moved = transform.copy()
            moved[:3, 3] -= np.array([0.0, centre, approach_distance / 2])
            if approach_distance > 0 and not _along_axes(transform[:3, :3]):
                extents = np.abs(transform[:3, :3]) @ extents
                moved[:3, :3] = np.eye(3)
            stretch = np.abs(moved[:3, :3].T @ np.array([0.0, 0.0, 1.0]))
            swept.append((moved, extents + stretch * approach_distance))
        return swept

    def collides(
        self,
        pose_world: np.ndarray,
        width: float,
        bodies: Sequence[ConvexBody | trimesh.Trimesh] | BodySet,
        table_z: float | None = None,
        approach_distance: float = 0.0,
        boxes: list[Box] | None = None,
    ) -> bool:
        """Whether the gripper at ``pose_world`` (the grasp frame, 4x4), opened to ``width``,
        hits a body or reaches below ``table_z``; with ``approach_distance``, anywhere on the
        straight approach from ``approach_distance`` metres back along -z to the pose."""
        poses = np.asarray(pose_world, float)[None]
        return bool(self.collisions(poses, width, bodies, table_z, approach_distance, boxes)[0])

    def collisions(
        self,
        poses_world: np.ndarray,
        width: float,
        bodies: Sequence[ConvexBody | trimesh.Trimesh] | BodySet,
        table_z: float | None = None,
        approach_distance: float = 0.0,
        boxes: list[Box] | None = None,
    ) -> np.ndarray:
        """(P,) :meth:`collides` for each of ``poses_world`` (P, 4, 4), tested together: the
        table for every box first, then the bodies for the poses still clear. A caller trying
        many widths passes the bodies as one ``BodySet`` and ``boxes``
        (``self.boxes(width, approach_distance)``), made once per width."""
        if not isinstance(bodies, BodySet):
            bodies = BodySet(
                tuple(b if isinstance(b, ConvexBody) else ConvexBody.from_mesh(b) for b in bodies)
            )
        boxes = boxes or self.boxes(width, approach_distance)
        local = np.stack([transform for transform, _ in boxes])  # (K, 4, 4)
        extents = np.stack([extents for _, extents in boxes])  # (K, 3)
        transforms = poses_world[:, None] @ local[None]  # (P, K, 4, 4)
        hit = np.zeros(len(poses_world), bool)
        if table_z is not None:
            lowest = transforms[..., 2, 3] - (np.abs(transforms[..., 2, :3]) * extents).sum(2) / 2
            hit = (lowest < table_z).any(axis=1)
        clear = np.flatnonzero(~hit)
        if clear.size:
            hit[clear] = bodies.hit_by_boxes(
                transforms[clear].reshape(-1, 4, 4),
                np.tile(extents, (clear.size, 1)),
                owners=np.repeat(np.arange(clear.size), len(boxes)),
            )
        return hit


def _along_axes(rotation: np.ndarray) -> bool:
    """Whether each of the rotation's columns lies along a coordinate axis."""
    return bool(np.all(np.isclose(np.abs(rotation).max(axis=0), 1.0, atol=1e-9)))


def _aligned_box(frame: np.ndarray, points: np.ndarray) -> Box:
    """The box around ``points`` (in ``frame``), aligned with the axes ``frame`` is in."""
    moved = points @ frame[:3, :3].T + frame[:3, 3]
    lo, hi = moved.min(axis=0), moved.max(axis=0)
    centre = np.eye(4)
    centre[:3, 3] = (lo + hi) / 2
    return centre, hi - lo


def _mesh(path: str | Path) -> trimesh.Trimesh:
    mesh = trimesh.load(path, force="mesh")
    assert isinstance(mesh, trimesh.Trimesh)  # force="mesh" makes one mesh
    return mesh


def _shape_points(shape: Geometry) -> np.ndarray:
    """(N, 3) a collision shape's points in its link's frame: a mesh's vertices, a primitive's
    box corners."""
    if shape.kind == "mesh":
        assert shape.mesh is not None
        points = np.asarray(_mesh(shape.mesh).vertices, np.float64)
        points = points * np.asarray(shape.scale)
    else:
        centre, extents = _shape_box(shape)
        signs = np.array(np.meshgrid(*[[-0.5, 0.5]] * 3)).reshape(3, -1).T
        return (signs * extents) @ centre[:3, :3].T + centre[:3, 3]
    return points @ shape.origin[:3, :3].T + shape.origin[:3, 3]


def _subtree_points(urdf: Urdf, poses, links: list[str], frame) -> tuple[np.ndarray, ...]:
    """Each collision shape's points of ``links``, in the frame whose inverse is ``frame``."""
    out = []
    for link in links:
        to_frame = frame @ poses[link]
        for shape in urdf.links[link].collisions:
            points = _shape_points(shape)
            out.append(points @ to_frame[:3, :3].T + to_frame[:3, 3])
    return tuple(out)


def _shape_box(shape: Geometry, oriented: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(4, 4) centre in the link's frame and (3,) full extents of a collision shape's box: a
    mesh's box aligned with its link's axes, or with ``oriented`` its tightest (trimesh's
    oriented bounding box: a jaw's convex pieces lie at angles to their link)."""
    centre = np.eye(4)
    if shape.kind == "box":
        extents = np.asarray(shape.size, float)
    elif shape.kind == "cylinder":
        radius, length = shape.size
        extents = np.array([2 * radius, 2 * radius, length])
    elif shape.kind == "sphere":
        extents = np.full(3, 2 * shape.size[0])
    else:
        assert shape.mesh is not None
        mesh = _mesh(shape.mesh)
        if oriented:
            mesh.apply_transform(np.diag([*shape.scale, 1.0]))
            obb = mesh.bounding_box_oriented
            return shape.origin @ np.asarray(obb.primitive.transform, float), np.asarray(
                obb.primitive.extents, float
            )
        bounds = np.asarray(mesh.bounds, float) * np.asarray(shape.scale)
        lo, hi = bounds.min(axis=0), bounds.max(axis=0)
        centre[:3, 3], extents = (lo + hi) / 2, hi - lo
    return shape.origin @ centre, extents


def _subtree_boxes(
    urdf: Urdf, poses: dict[str, np.ndarray], links: list[str], frame, oriented: bool = False
) -> list:
    """Boxes of ``links``' shapes in the frame whose inverse is ``frame``."""
    return [
        (frame @ poses[link] @ centre, extents)
        for link in links
        for shape in urdf.links[link].collisions
        for centre, extents in [_shape_box(shape, oriented)]
    ]


def _merged(boxes: list[Box]) -> Box:
    """The axis-aligned box around ``boxes`` (in the TCP frame)."""
    corners = []
    for transform, extents in boxes:
        signs = np.array(np.meshgrid(*[[-0.5, 0.5]] * 3)).reshape(3, -1).T
        corners.append((transform[:3, :3] @ (signs * extents).T).T + transform[:3, 3])
    points = np.concatenate(corners)
    centre = np.eye(4)
    centre[:3, 3] = (points.min(axis=0) + points.max(axis=0)) / 2
    return centre, points.max(axis=0) - points.min(axis=0)


def _pad_table(urdf: Urdf, gripper: GripperSpec, values: np.ndarray):
    """(widths, centres) of the pads at each joint value (the module docstring)."""
    widths, centres = [], []
    for q in values:
        poses = urdf.link_poses(dict.fromkeys(gripper.finger_joints, float(q)))
        tcp_inv = np.linalg.inv(poses[gripper.tcp_link])
        first, second = ((tcp_inv @ poses[pad])[1, 3] for pad in gripper.pads)
        widths.append(first - second)
        centres.append((first + second) / 2)
    return np.round(widths, DECIMALS) + 0.0, np.round(centres, DECIMALS) + 0.0


def _finger_links(urdf: Urdf, gripper: GripperSpec) -> list[list[str]]:
    """Each finger's subtree, the other finger's subtree excepted (a jaw's fixed finger is the
    hand-side link the moving jaw hangs from)."""
    out = []
    for finger, other in (gripper.finger_links, gripper.finger_links[::-1]):
        below = set(urdf.subtree(other)) if other in urdf.subtree(finger) else set()
        out.append([link for link in urdf.subtree(finger) if link not in below])
    return out


def derive_geometry(urdf: Urdf, gripper: GripperSpec, name: str = "") -> GripperGeometry:
    where = f"robot {name!r} gripper"
    for link in (gripper.hand_link, gripper.tcp_link, *gripper.finger_links, *gripper.pads):
        if link not in urdf.links:
            raise ValueError(f"{where}: no link {link!r} in {urdf.name}")
    kinds = {urdf.joints[j].kind if j in urdf.joints else "missing" for j in gripper.finger_joints}
    expected = {"revolute"} if gripper.jaw else {"prismatic"}
    if kinds != expected:
        raise ValueError(
            f"{where}: finger_joints {gripper.finger_joints} are {sorted(kinds)}, expected one revolute or two prismatic"
        )
    closed = {joint: gripper.finger_travel[0] for joint in gripper.finger_joints}
    poses = urdf.link_poses(closed)
    tcp_inv = np.linalg.inv(poses[gripper.tcp_link])
    step = {joint: gripper.finger_travel[0] + 0.01 for joint in gripper.finger_joints}
    opened = urdf.link_poses(step)
    fingers, finger_links = [], set()
    for finger, links in zip(gripper.finger_links, _finger_links(urdf, gripper), strict=True):
        finger_links |= set(links)
        joint = next((j for j in urdf.joints.values() if j.child == finger), None)
        if gripper.jaw and joint is not None and joint.name == gripper.finger_joints[0]:
            frame = tcp_inv @ poses[joint.parent] @ joint.origin
            at_zero = urdf.link_poses(dict.fromkeys(gripper.finger_joints, 0.0))
            pieces = _subtree_points(urdf, at_zero, links, np.linalg.inv(at_zero[finger]))
            fingers.append(Finger((), joint=joint, frame=frame, pieces=pieces))
            continue
        if gripper.jaw:  # the fixed jaw, part of the hand
            fingers.append(Finger((), pieces=_subtree_points(urdf, poses, links, tcp_inv)))
            continue
        boxes = tuple(_subtree_boxes(urdf, poses, links, tcp_inv, oriented=True))
        moved = tcp_inv[:3, :3] @ (opened[finger][:3, 3] - poses[finger][:3, 3])
        direction = None if gripper.jaw else moved / np.linalg.norm(moved)
        fingers.append(Finger(boxes, direction=direction))
    hand_links = [link for link in urdf.subtree(gripper.hand_link) if link not in finger_links]
    hand = _subtree_boxes(urdf, poses, hand_links, tcp_inv)
    samples = JAW_SAMPLES if gripper.jaw else 2
    values = np.linspace(*gripper.finger_travel, samples)
    widths, centres = _pad_table(urdf, gripper, values)
    if np.any(np.diff(widths) <= 0):
        raise ValueError(
            f"{where}: the width is not increasing over finger_travel {gripper.finger_travel}"
        )
    return GripperGeometry(
        fingers=(fingers[0], fingers[1]),
        hand_boxes=(_merged(hand),) if hand else (),
        joint_values=values,
        widths=widths,
        centres=centres,
    )


@functools.lru_cache(maxsize=8)
def gripper_geometry(spec: RobotSpec) -> GripperGeometry:
    """The gripper of ``spec`` as boxes, read from its description once per process."""
    return derive_geometry(read_urdf(spec.urdf_path()), spec.gripper, spec.name)
