"""The Panda gripper as boxes in the TCP frame, and exact box-vs-convex collision checks.

Boxes are from ManiSkill's ``panda_v2.urdf`` (their sizes: :mod:`datagen.robot_specs.panda`):
the TCP is in front of ``panda_hand``, the fingers slide along +-y. Each finger is its rubber
pad (the URDF's tip box, inner face at y = +-width/2) and one box around its diagonal and screw
mount; the hand is the bounding box of ``meshes/collision/hand.stl``.
The arm behind the hand is not modelled (reachability belongs to the motion planner).

Collision is a separating-axis test between each (oriented) box and each obstacle, taken as a
convex polyhedron: exact for convex parts, conservative (the convex hull) for anything else,
so pass objects as their convex parts. The approach path, a translation along -z of the TCP
frame, is checked exactly by stretching every box over the swept distance.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh

from datagen.robot_specs.panda import PANDA

_GRIPPER = PANDA.gripper
TCP_FROM_HAND = _GRIPPER.tcp_from_hand
PAD = _GRIPPER.pad
PAD_Z = _GRIPPER.finger_origin + _GRIPPER.pad_centre - TCP_FROM_HAND  # in the TCP frame (~0.0003)
FINGER_BODY = _GRIPPER.finger_body
FINGER_BODY_Z = (  # its centre in the TCP frame
    _GRIPPER.finger_origin + _GRIPPER.finger_body_start + FINGER_BODY[2] / 2 - TCP_FROM_HAND
)


@dataclass(frozen=True)
class ConvexBody:
    """A convex polyhedron: vertices, face planes (n . x <= offset inside) and SAT axes."""

    vertices: np.ndarray  # (V, 3)
    normals: np.ndarray  # (F, 3) unit outward face normals, duplicates merged
    offsets: np.ndarray  # (F,)
    edges: np.ndarray  # (E, 3) unit edge directions, duplicates merged
    bounds: np.ndarray  # (2, 3) axis-aligned bounds

    @classmethod
    def from_mesh(cls, mesh: trimesh.Trimesh) -> ConvexBody:
        vertices = np.asarray(mesh.vertices, float)
        normals = np.asarray(mesh.face_normals, float)
        offsets = np.einsum("ij,ij->i", normals, vertices[mesh.faces[:, 0]])
        planes = np.unique(np.round(np.c_[normals, offsets], 9), axis=0)
        edges = np.diff(vertices[mesh.edges_unique], axis=1)[:, 0]
        edges = edges / np.linalg.norm(edges, axis=1, keepdims=True)
        edges = edges * np.where(edges[:, [0]] < 0, -1.0, 1.0)  # canonical sign
        edges = np.unique(np.round(edges, 6), axis=0)
        return cls(vertices, planes[:, :3], planes[:, 3], edges, np.asarray(mesh.bounds, float))

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Signed distance-like value per point: max over planes of n . p - offset (< 0 inside)."""
        return (np.atleast_2d(points) @ self.normals.T - self.offsets).max(axis=1)


def gripper_boxes(
    width: float, approach_distance: float = 0.0
) -> list[tuple[np.ndarray, np.ndarray]]:
    """(transform in the TCP frame, full extents) of each box, fingers opened to ``width``.

    With ``approach_distance`` > 0 each box is stretched back along -z by that distance: the
    volume the box sweeps while the gripper moves in from the pre-grasp pose.
    """
    boxes = []
    for side in (1.0, -1.0):
        pad_y = side * (width / 2 + PAD[1] / 2)
        boxes.append(((0.0, pad_y, PAD_Z), PAD))
        body_y = side * (width / 2 + _GRIPPER.finger_body_gap + FINGER_BODY[1] / 2)
        boxes.append(((0.0, body_y, FINGER_BODY_Z), FINGER_BODY))
    lo, hi = np.asarray(_GRIPPER.hand_bounds)
    boxes.append(((lo + hi) / 2 - (0, 0, TCP_FROM_HAND), tuple(hi - lo)))
    out = []
    for centre, extents in boxes:
        transform = np.eye(4)
        transform[:3, 3] = centre
        transform[2, 3] -= approach_distance / 2
        out.append((transform, np.add(extents, (0.0, 0.0, approach_distance))))
    return out


def box_hits_body(transform: np.ndarray, extents: np.ndarray, body: ConvexBody) -> bool:
    """Separating-axis test of an oriented box (world transform, full extents) and a body."""
    rot, centre, half = transform[:3, :3], transform[:3, 3], np.asarray(extents) / 2
    reach = np.abs(rot) @ half
    if np.any(centre + reach < body.bounds[0]) or np.any(centre - reach > body.bounds[1]):
        return False
    cross = np.cross(rot.T[:, None, :], body.edges[None, :, :]).reshape(-1, 3)
    axes = np.concatenate([rot.T, body.normals, cross])
    norms = np.linalg.norm(axes, axis=1)
    axes = axes[norms > 1e-9] / norms[norms > 1e-9, None]
    proj = body.vertices @ axes.T
    box_c = axes @ centre
    box_r = np.abs(axes @ rot) @ half
    separated = (box_c + box_r < proj.min(axis=0)) | (box_c - box_r > proj.max(axis=0))
    return not separated.any()


def collides(
    pose_world: np.ndarray,
    width: float,
    bodies: Sequence[ConvexBody | trimesh.Trimesh],
    table_z: float | None = None,
    approach_distance: float = 0.0,
) -> bool:
    """Whether the gripper at ``pose_world`` (TCP, 4x4), opened to ``width``, hits a body or
    reaches below ``table_z``; with ``approach_distance``, anywhere on the straight approach
    from ``approach_distance`` metres back along -z to the pose."""
    bodies = [b if isinstance(b, ConvexBody) else ConvexBody.from_mesh(b) for b in bodies]
    for local, extents in gripper_boxes(width, approach_distance):
        transform = pose_world @ local
        if table_z is not None:
            lowest = transform[2, 3] - np.abs(transform[2, :3]) @ (extents / 2)
            if lowest < table_z:
                return True
        if any(box_hits_body(transform, extents, body) for body in bodies):
            return True
    return False
