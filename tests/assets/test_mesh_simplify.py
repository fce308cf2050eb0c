"""Meshes with fewer triangles (datagen/assets/mesh_simplify.py): the triangle budget holds, the
shape stays, hard edges stay hard, the result is the same every time, budgets share out."""

from __future__ import annotations

import numpy as np
import trimesh

from datagen.assets.mesh_simplify import (
    decimated,
    face_budgets,
    simplified_with_normals,
    welded,
)


def _unwelded(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """Three vertices per triangle, as CAD exports ship them (the Panda's GLB files)."""
    return mesh.vertices[mesh.faces].reshape(-1, 3), np.arange(3 * len(mesh.faces)).reshape(-1, 3)


def test_welding_joins_vertices_split_at_seams():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    mesh = welded(*_unwelded(sphere))
    assert len(mesh.vertices) == len(sphere.vertices) and len(mesh.faces) == len(sphere.faces)


def test_a_mesh_is_decimated_to_its_budget_and_keeps_its_shape():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.1)  # 5,120 triangles
    vertices, faces, normals = simplified_with_normals(*_unwelded(sphere), max_faces=500)
    assert 400 <= len(faces) <= 500
    radii = np.linalg.norm(vertices, axis=1)
    assert np.abs(radii - 0.1).max() < 0.004  # metres: still the sphere
    # smooth: each normal points away from the centre, as the sphere's does
    assert np.min(np.sum(normals * vertices / radii[:, None], axis=1)) > 0.95
    assert vertices.dtype == np.float32 and faces.dtype == np.uint32


def test_hard_edges_stay_hard_and_the_mesh_stays_closed():
    box = trimesh.creation.box(extents=(0.2, 0.1, 0.05)).subdivide().subdivide()  # 192 triangles
    vertices, faces, normals = simplified_with_normals(*_unwelded(box), max_faces=60)
    # every normal is a face normal of the box: no shading bends round its corners
    assert np.allclose(np.abs(normals).max(axis=1), 1.0, atol=1e-5)
    closed = trimesh.Trimesh(vertices, faces, process=True)  # welded again by position
    assert closed.is_watertight
    assert np.allclose(closed.extents, (0.2, 0.1, 0.05), atol=1e-6)


def test_a_mesh_within_its_budget_is_only_welded():
    sphere = trimesh.creation.icosphere(subdivisions=2)
    vertices, faces = decimated(*_unwelded(sphere), max_faces=len(sphere.faces))
    assert len(faces) == len(sphere.faces) and len(vertices) == len(sphere.vertices)


def test_the_same_input_gives_the_same_bytes():
    mesh = trimesh.creation.capsule(height=0.1, radius=0.03, count=[48, 48])
    first = simplified_with_normals(*_unwelded(mesh), max_faces=300)
    second = simplified_with_normals(*_unwelded(mesh), max_faces=300)
    assert all(np.array_equal(a, b) for a, b in zip(first, second, strict=True))


def test_budgets_are_shared_by_triangles_and_small_meshes_keep_theirs():
    assert face_budgets([100, 300], 1000) == [100, 300]  # within the budget: unchanged
    # the small mesh keeps its 20; the others share 980 by their triangles
    assert face_budgets([9000, 1000, 20], 1000, floor=32) == [882, 98, 20]
    # 800 triangles would get 81: it gets its floor, the other what is left
    assert face_budgets([9000, 800], 1000, floor=500) == [500, 500]
    assert face_budgets([9000, 800, 600], 1000, floor=500) == [500, 500, 500]  # floors only
    assert face_budgets([5000, 3000, 2000, 1500, 40], 6000, 1000) == [2475, 1485, 1000, 1000, 40]
