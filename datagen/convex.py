"""Exact collision checks of convex polyhedra: a convex body and separating-axis tests (box
against body, body against body).

Collision is a separating-axis test between an oriented box and an obstacle, taken as a convex
polyhedron: exact for convex parts, conservative (the convex hull) for anything else, so pass
objects as their convex parts. The gripper's boxes: :mod:`datagen.families.grasp_attempts.gripper_geometry`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import trimesh


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


@dataclass(frozen=True)
class BodySet:
    """Bodies tested together: their bounds stacked once, so that one box is checked against
    every body's bounds in one step and only the bodies it may touch get the full test."""

    bodies: tuple[ConvexBody, ...]

    @cached_property
    def lows(self) -> np.ndarray:  # (B, 3)
        return np.array([b.bounds[0] for b in self.bodies]).reshape(-1, 3)

    @cached_property
    def highs(self) -> np.ndarray:  # (B, 3)
        return np.array([b.bounds[1] for b in self.bodies]).reshape(-1, 3)

    def hit_by_box(self, transform: np.ndarray, extents: np.ndarray) -> bool:
        """Whether the oriented box (world transform, full extents) meets any body: the bounds
        test of ``box_hits_body`` for all bodies at once, then the full test where it passes."""
        centre, reach = transform[:3, 3], np.abs(transform[:3, :3]) @ (np.asarray(extents) / 2)
        near = np.all((centre + reach >= self.lows) & (centre - reach <= self.highs), axis=1)
        return any(box_hits_body(transform, extents, self.bodies[k]) for k in np.flatnonzero(near))


def box_hits_body(transform: np.ndarray, extents: np.ndarray, body: ConvexBody) -> bool:
    """Separating-axis test of an oriented box (world transform, full extents) and a body. The
    axes are tried cheapest first (the box's 3 face normals, the body's face normals, then the
    cross products of their edges): the first that separates answers."""
    rot, centre, half = transform[:3, :3], transform[:3, 3], np.asarray(extents) / 2
    reach = np.abs(rot) @ half
    if np.any(centre + reach < body.bounds[0]) or np.any(centre - reach > body.bounds[1]):
        return False
    if _separated(rot.T, rot, centre, half, body.vertices):
        return False
    if _separated(body.normals, rot, centre, half, body.vertices):
        return False
    cross = np.cross(rot.T[:, None, :], body.edges[None, :, :]).reshape(-1, 3)
    norms = np.linalg.norm(cross, axis=1)
    cross = cross[norms > 1e-9] / norms[norms > 1e-9, None]
    return not _separated(cross, rot, centre, half, body.vertices)


def _separated(axes, rot, centre, half, vertices) -> bool:
    """Whether one of ``axes`` (unit vectors, (A, 3)) separates the box from ``vertices``."""
    proj = vertices @ axes.T
    box_c = axes @ centre
    box_r = np.abs(axes @ rot) @ half
    return bool(((box_c + box_r < proj.min(axis=0)) | (box_c - box_r > proj.max(axis=0))).any())


def bodies_meet(a: ConvexBody, b: ConvexBody, clearance: float = 0.0) -> bool:
    """Separating-axis test of two convex bodies: whether they come within ``clearance`` metres
    along every axis (face normals of both, cross products of their edges)."""
    if np.any(a.bounds[1] + clearance < b.bounds[0]) or np.any(
        b.bounds[1] + clearance < a.bounds[0]
    ):
        return False
    cross = np.cross(a.edges[:, None, :], b.edges[None, :, :]).reshape(-1, 3)
    axes = np.concatenate([a.normals, b.normals, cross])
    norms = np.linalg.norm(axes, axis=1)
    axes = axes[norms > 1e-9] / norms[norms > 1e-9, None]
    pa, pb = a.vertices @ axes.T, b.vertices @ axes.T
    separated = (pa.max(axis=0) + clearance < pb.min(axis=0)) | (
        pb.max(axis=0) + clearance < pa.min(axis=0)
    )
    return not separated.any()
