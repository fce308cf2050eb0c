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

CORNER_SIGNS = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).reshape(3, -1).T  # (8, 3)


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

    @cached_property
    def face_extents(self) -> tuple[np.ndarray, np.ndarray]:
        """(F,) lowest and highest projection of the vertices on each face normal: the body's
        side of its own separating-axis tests, computed once (a box is tested against a body
        many times)."""
        proj = self.vertices @ self.normals.T
        return proj.min(axis=0), proj.max(axis=0)

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
        """Whether the oriented box (world transform, full extents) meets any body."""
        return bool(self.hit_by_boxes(transform[None], np.asarray(extents, float)[None])[0])

    def hit_by_boxes(self, transforms: np.ndarray, extents: np.ndarray) -> np.ndarray:
        """(N,) whether each oriented box (transforms (N, 4, 4) in the world, full extents
        (N, 3)) meets any body: one bounds test of every box against every body, then, body by
        body, the full test of the boxes near it not yet known to hit."""
        rot, centre, half = transforms[:, :3, :3], transforms[:, :3, 3], extents / 2
        reach = _rows_dot(np.abs(rot), half)
        near = np.all(
            ((centre + reach)[:, None] >= self.lows) & ((centre - reach)[:, None] <= self.highs),
            axis=2,
        )  # (N, B)
        hit = np.zeros(len(transforms), bool)
        for k in np.flatnonzero(near.any(axis=0)):
            boxes = np.flatnonzero(near[:, k] & ~hit)
            if boxes.size:
                hit[boxes] = boxes_hit_body(rot[boxes], centre[boxes], half[boxes], self.bodies[k])
        return hit


def box_hits_body(transform: np.ndarray, extents: np.ndarray, body: ConvexBody) -> bool:
    """Separating-axis test of an oriented box (world transform, full extents) and a body."""
    rot, centre, half = transform[:3, :3], transform[:3, 3], np.asarray(extents, float) / 2
    reach = np.abs(rot) @ half
    if np.any(centre + reach < body.bounds[0]) or np.any(centre - reach > body.bounds[1]):
        return False
    return bool(boxes_hit_body(rot[None], centre[None], half[None], body)[0])


def boxes_hit_body(
    rot: np.ndarray, centre: np.ndarray, half: np.ndarray, body: ConvexBody
) -> np.ndarray:
    """(n,) separating-axis tests of n oriented boxes (rotations (n, 3, 3), centres (n, 3),
    half extents (n, 3)) against one body. The axes are tried cheapest first, for all boxes at
    once: the boxes' own face normals, the body's face normals (its side precomputed), then,
    box by box for those still not separated, the cross products of their edges. Dot products
    are written out term by term, so a box's answer does not depend on the batch it is in."""
    vertices = body.vertices
    # box axis k of box i is rot[i, :, k]
    proj = sum(vertices[None, :, j, None] * rot[:, None, j, :] for j in range(3))  # (n, V, 3)
    along_own = _rows_dot(rot.transpose(0, 2, 1), centre)  # (n, 3)
    separated = ((along_own + half < proj.min(axis=1)) | (along_own - half > proj.max(axis=1))).any(
        axis=1
    )
    left = np.flatnonzero(~separated)
    if left.size:
        normals = body.normals
        lows, highs = body.face_extents
        along = sum(centre[left, None, j] * normals[None, :, j] for j in range(3))  # (m, F)
        turned = sum(normals[None, :, j, None] * rot[left, None, j, :] for j in range(3))
        radius = sum(np.abs(turned[..., k]) * half[left, None, k] for k in range(3))
        separated[left] = ((along + radius < lows) | (along - radius > highs)).any(axis=1)
    left = np.flatnonzero(~separated)
    if left.size:  # a body vertex in a box or a box corner in the body: they meet, no more axes
        offset = np.abs(proj[left] - along_own[left, None])
        meet = (offset <= half[left, None]).all(axis=2).any(axis=1)
        corners = centre[left, None] + sum(
            rot[left, None, :, k] * (CORNER_SIGNS[None, :, k, None] * half[left, None, k, None])
            for k in range(3)
        )  # (m, 8, 3)
        level = sum(corners[:, :, None, j] * body.normals[None, None, :, j] for j in range(3))
        meet |= (level <= body.face_extents[1]).all(axis=2).any(axis=1)
        left = left[~meet]
    for i in left:
        cross = _cross(rot[i].T, body.edges)
        norms = np.linalg.norm(cross, axis=1)
        cross = cross[norms > 1e-9] / norms[norms > 1e-9, None]
        separated[i] = _separated(cross, rot[i], centre[i], half[i], vertices)
    return ~separated


def _rows_dot(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """(n, 3) each matrix (n, 3, 3) times its vector (n, 3), term by term."""
    return sum(matrices[:, :, j] * vectors[:, j, None] for j in range(3))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(A * B, 3) every a x b, as ``np.cross(a[:, None], b[None]).reshape(-1, 3)`` computes
    them, without its axis juggling (a hot path of the samplers)."""
    a0, a1, a2 = a[:, 0, None], a[:, 1, None], a[:, 2, None]
    b0, b1, b2 = b[None, :, 0], b[None, :, 1], b[None, :, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1).reshape(
        -1, 3
    )


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
