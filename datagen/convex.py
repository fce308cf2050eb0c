"""Exact collision checks of convex polyhedra: a convex body, oriented boxes against bodies
(separating axes, then vertices and edges) and bodies against bodies (separating axes).

An obstacle is taken as a convex polyhedron: exact for convex parts, conservative (the convex
hull) for anything else, so pass objects as their convex parts. The gripper's boxes:
:mod:`datagen.families.grasp_attempts.gripper_geometry`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import trimesh

NEAR_GAP = 1e-9  # metres; see BodySet._near
CONVEX_TOLERANCE = 1e-7  # metres a vertex may lie outside a face of a mesh taken as convex
CORNER_SIGNS = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).reshape(3, -1).T  # (8, 3)
BOX_EDGES = np.array(
    [
        (a, b)
        for a in range(8)
        for b in range(a + 1, 8)
        if np.abs(CORNER_SIGNS[a] - CORNER_SIGNS[b]).sum() == 2
    ]
)  # (12, 2) corner indices


@dataclass(frozen=True)
class ConvexBody:
    """A convex polyhedron: vertices, face planes (n . x <= offset inside) and SAT axes."""

    vertices: np.ndarray  # (V, 3)
    normals: np.ndarray  # (F, 3) unit outward face normals, duplicates merged
    offsets: np.ndarray  # (F,)
    edges: np.ndarray  # (E, 3) unit edge directions, duplicates merged
    bounds: np.ndarray  # (2, 3) axis-aligned bounds
    segments: np.ndarray  # (S, 2) vertex indices of each edge

    @classmethod
    def from_mesh(cls, mesh: trimesh.Trimesh) -> ConvexBody:
        """The body of a convex mesh; of anything else (a vertex more than ``CONVEX_TOLERANCE``
        outside a face's plane), its convex hull's."""
        vertices, normals, offsets = _faces(mesh)
        if (vertices @ normals.T - offsets).max(initial=0.0) > CONVEX_TOLERANCE:
            mesh = mesh.convex_hull
            vertices, normals, offsets = _faces(mesh)
        planes = np.unique(np.round(np.c_[normals, offsets], 9), axis=0)
        edges = np.diff(vertices[mesh.edges_unique], axis=1)[:, 0]
        edges = edges / np.linalg.norm(edges, axis=1, keepdims=True)
        edges = edges * np.where(edges[:, [0]] < 0, -1.0, 1.0)  # canonical sign
        edges = np.unique(np.round(edges, 6), axis=0)
        segments = np.asarray(mesh.edges_unique, np.intp)
        bounds = np.asarray(mesh.bounds, float)
        return cls(vertices, planes[:, :3], planes[:, 3], edges, bounds, segments)

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


def _faces(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices (V, 3), face normals (F, 3), face offsets (F,)) of a mesh."""
    vertices = np.asarray(mesh.vertices, float)
    normals = np.asarray(mesh.face_normals, float)
    return vertices, normals, np.einsum("ij,ij->i", normals, vertices[mesh.faces[:, 0]])


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

    @cached_property
    def centres(self) -> np.ndarray:  # (B, 3) the bounds' centres
        return (self.lows + self.highs) / 2

    @cached_property
    def half_sizes(self) -> np.ndarray:  # (B, 3) the bounds' half extents
        return (self.highs - self.lows) / 2

    def hit_by_box(self, transform: np.ndarray, extents: np.ndarray) -> bool:
        """Whether the oriented box (world transform, full extents) meets any body."""
        return bool(self.hit_by_boxes(transform[None], np.asarray(extents, float)[None])[0])

    def hit_by_boxes(
        self, transforms: np.ndarray, extents: np.ndarray, owners: np.ndarray | None = None
    ) -> np.ndarray:
        """(N,) whether each oriented box (transforms (N, 4, 4) in the world, full extents
        (N, 3)) meets any body. With ``owners`` ((N,) the index of the group each box belongs
        to, such as the gripper pose it is part of), (G,) whether any box of each group meets
        one: a group's boxes are not tested once one of them hit.

        The bodies' bounds are tested against every box at once, along the world's axes and
        the box's own (a necessary condition for a hit); then, body by body, the boxes near it
        whose answer is not yet known get the full test."""
        rot, centre, half = transforms[:, :3, :3], transforms[:, :3, 3], extents / 2
        near = self._near(rot, centre, half)  # (N, B)
        owners = np.arange(len(transforms)) if owners is None else np.asarray(owners)
        hit = np.zeros(int(owners.max(initial=-1)) + 1, bool)
        for k in np.flatnonzero(near.any(axis=0)):
            boxes = np.flatnonzero(near[:, k] & ~hit[owners])
            if boxes.size:
                met = boxes_hit_body(rot[boxes], centre[boxes], half[boxes], self.bodies[k])
                hit[owners[boxes[met]]] = True
        return hit

    def _near(self, rot: np.ndarray, centre: np.ndarray, half: np.ndarray) -> np.ndarray:
        """(N, B) whether each box overlaps each body's bounds along the world's axes and along
        the box's: where it does not, the box misses the body. A gap must exceed ``NEAR_GAP``,
        so that the full test, whose sums round differently, never finds a meeting here."""
        reach = _rows_dot(np.abs(rot), half)
        near = np.all(
            ((centre + reach)[:, None] >= self.lows) & ((centre - reach)[:, None] <= self.highs),
            axis=2,
        )
        offset = self.centres[None] - centre[:, None]  # (N, B, 3) world
        for k in range(3):  # box axis k is rot[:, :, k]
            axis = rot[:, None, :, k]  # (N, 1, 3)
            along = sum(offset[..., j] * axis[..., j] for j in range(3))  # (N, B)
            radius = sum(np.abs(axis[..., j]) * self.half_sizes[None, :, j] for j in range(3))
            near &= np.abs(along) <= half[:, None, k] + radius + NEAR_GAP
        return near


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
    """(n,) whether each of n oriented boxes (rotations (n, 3, 3), centres (n, 3), half extents
    (n, 3)) meets one body. For all boxes at once, cheapest first: separating axes along the
    boxes' own face normals, then the body's (its side precomputed); for the boxes still not
    separated, a body vertex in the box or a box corner in the body; for the rest, a box edge
    through the body or a body edge through the box (:func:`_edges_meet`). Dot products are
    written out term by term, so a box's answer does not depend on the batch it is in."""
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
    if not left.size:
        return ~separated
    inside = proj[left] - along_own[left, None]  # (m, V, 3) body vertices in each box's frame
    meet = (np.abs(inside) <= half[left, None]).all(axis=2).any(axis=1)
    corners = centre[left, None] + sum(
        rot[left, None, :, k] * (CORNER_SIGNS[None, :, k, None] * half[left, None, k, None])
        for k in range(3)
    )  # (m, 8, 3)
    level = sum(corners[:, :, None, j] * body.normals[None, None, :, j] for j in range(3))
    meet |= (level <= body.face_extents[1]).all(axis=2).any(axis=1)
    rest = np.flatnonzero(~meet)
    if rest.size:
        meet[rest] = _edges_meet(
            level[rest], body.face_extents[1], inside[rest], half[left[rest]], body.segments
        )
    separated[left] = ~meet
    return ~separated


def _edges_meet(
    level: np.ndarray, highs: np.ndarray, inside: np.ndarray, half: np.ndarray, segments
) -> np.ndarray:
    """(m,) whether a box edge passes through the body or a body edge through the box, for m
    boxes with no corner in the body and none of its vertices inside them: then these are the
    only ways two convex polyhedra meet (a vertex of their intersection lies on an edge of one,
    in the other). ``level`` (m, 8, F): the box corners on the body's face normals, whose
    ``highs`` (F,) bound the body; ``inside`` (m, V, 3): the body's vertices in each box's frame,
    ``half`` (m, 3) the boxes' half extents; ``segments`` (S, 2) the body's edges."""
    # a box edge clipped by each face plane to its part inside, as t in [0, 1] from corner a to b
    gap_a = level[:, BOX_EDGES[:, 0]] - highs  # (m, 12, F), <= 0 inside the plane
    gap_b = level[:, BOX_EDGES[:, 1]] - highs
    crossing = (gap_a > 0) != (gap_b > 0)
    t = gap_a / np.where(crossing, gap_a - gap_b, 1.0)
    t_enter = np.where(crossing & (gap_a > 0), t, 0.0).max(axis=2)
    t_exit = np.where(crossing & (gap_b > 0), t, 1.0).min(axis=2)
    outside = ((gap_a > 0) & (gap_b > 0)).any(axis=2)
    meet = (~outside & (t_enter <= t_exit)).any(axis=1)
    # a body edge against each box: the segment-box separating-axis test (the box's 3 axes and
    # their cross products with the segment), no division
    start, end = inside[:, segments[:, 0]], inside[:, segments[:, 1]]  # (m, S, 3)
    mid, along = (start + end) / 2, (end - start) / 2
    h = half[:, None]
    apart = (np.abs(mid) > h + np.abs(along)).any(axis=2)
    for k in range(3):  # the axis e_k x along
        i, j = (k + 1) % 3, (k + 2) % 3
        offset = mid[..., j] * along[..., i] - mid[..., i] * along[..., j]
        apart |= np.abs(offset) > h[..., i] * np.abs(along[..., j]) + h[..., j] * np.abs(
            along[..., i]
        )
    return meet | (~apart).any(axis=1)


def _rows_dot(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """(n, 3) each matrix (n, 3, 3) times its vector (n, 3), term by term."""
    return sum(matrices[:, :, j] * vectors[:, j, None] for j in range(3))


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
