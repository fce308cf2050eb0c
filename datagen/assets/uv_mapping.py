"""Texture coordinates for any triangle mesh, in metres (pure: a mesh in, arrays out).

Box (triplanar) mapping: each triangle is projected along the axis its normal is closest to,
so a box gets one planar map per face, a cylinder's cap a planar map and its side two
projections that meet at 45 degrees (the usual seam of box mapping), and a convex hull or a
user's mesh a map that never stretches by more than sqrt(2). Coordinates are metres on the
surface (``textures.surface_uv`` turns them into repeats), so a pattern keeps its size on every
object. Vertices are split per triangle; normals stay smooth across edges sharper than
:data:`CREASE_DEG` only where the mesh is smooth, so boxes keep flat faces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

CREASE_DEG = 35.0  # a vertex normal further than this from its face's normal is replaced
# the two coordinates drawn on a face whose normal is closest to x, y or z
_PLANE_AXES = np.array([[1, 2], [0, 2], [0, 1]])


@dataclass(frozen=True)
class UVMesh:
    vertices: np.ndarray  # (3F, 3) float32, one vertex per triangle corner
    triangles: np.ndarray  # (F, 3) uint32
    normals: np.ndarray  # (3F, 3) float32
    uv_m: np.ndarray  # (3F, 2) float, metres on the surface


def box_mapped(mesh: trimesh.Trimesh) -> UVMesh:
    faces = np.asarray(mesh.faces)
    corners = np.asarray(mesh.vertices, float)[faces]  # (F, 3, 3)
    face_normals = np.asarray(mesh.face_normals, float)
    axis = np.argmax(np.abs(face_normals), axis=1)  # (F,)
    uv = np.take_along_axis(corners, _PLANE_AXES[axis][:, None, :], axis=2)  # (F, 3, 2)
    # seen from outside each face, the first coordinate runs right and the second down (a
    # texture's rows run down): a picture is drawn upright and never mirrored (on y faces the
    # plane's x runs left as seen from outside)
    sign = np.where(face_normals[np.arange(len(faces)), axis] < 0, -1.0, 1.0)
    uv[..., 0] *= np.where(axis == 1, -sign, sign)[:, None]
    uv[..., 1] *= -1.0
    smooth = np.asarray(mesh.vertex_normals, float)[faces]  # (F, 3, 3)
    cos_crease = np.cos(np.deg2rad(CREASE_DEG))
    keep = np.einsum("fcd,fd->fc", smooth, face_normals) > cos_crease
    normals = np.where(keep[..., None], smooth, face_normals[:, None, :])
    count = len(faces) * 3
    return UVMesh(
        corners.reshape(count, 3).astype(np.float32),
        np.arange(count, dtype=np.uint32).reshape(-1, 3),
        normals.reshape(count, 3).astype(np.float32),
        uv.reshape(count, 2),
    )


def box_with_uv(half_size) -> tuple[trimesh.Trimesh, UVMesh]:
    """An axis-aligned box centred at the origin, (half-extents in metres), with its map."""
    box = trimesh.creation.box(extents=2 * np.asarray(half_size, float))
    return box, box_mapped(box)
