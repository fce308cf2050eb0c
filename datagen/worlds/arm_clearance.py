"""Whether an arm posed without simulating (joints set, as the look pose is) meets an object:
each link's collision shapes and each object's convex parts as convex bodies in the world,
tested exactly by separating axes (:func:`datagen.convex.bodies_meet`)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import sapien
import trimesh

from datagen.convex import ConvexBody, bodies_meet

# points on a sphere standing in for a round shape (a sphere, a capsule's ends): an icosphere,
# its circumscribed radius the shape's, so the hull covers at least the shape
_SPHERE = trimesh.creation.icosphere(subdivisions=1)
_SPHERE_POINTS = np.asarray(_SPHERE.vertices, float) / np.cos(np.deg2rad(20.0))


def _shape_points(shape: sapien.physx.PhysxCollisionShape) -> np.ndarray | None:
    """(N, 3) points whose hull covers ``shape``, in its body's frame; None for a plane."""
    if isinstance(shape, sapien.physx.PhysxCollisionShapeBox):
        half = np.asarray(shape.half_size, float)
        points = np.array(np.meshgrid(*[[-h, h] for h in half])).reshape(3, -1).T
    elif isinstance(shape, sapien.physx.PhysxCollisionShapeConvexMesh):
        points = np.asarray(shape.get_vertices(), float) * np.asarray(shape.get_scale(), float)
    elif isinstance(shape, sapien.physx.PhysxCollisionShapeSphere):
        points = _SPHERE_POINTS * shape.radius
    elif isinstance(shape, sapien.physx.PhysxCollisionShapeCapsule):  # along its x
        ends = np.array([[shape.half_length, 0, 0], [-shape.half_length, 0, 0]])
        points = (ends[:, None, :] + _SPHERE_POINTS[None] * shape.radius).reshape(-1, 3)
    else:
        return None
    local = shape.get_local_pose().to_transformation_matrix()
    return points @ local[:3, :3].T + local[:3, 3]


def _body(points: np.ndarray, pose: np.ndarray) -> ConvexBody:
    world = points @ pose[:3, :3].T + pose[:3, 3]
    return ConvexBody.from_mesh(trimesh.convex.convex_hull(world))


def link_bodies(links: Iterable[sapien.physx.PhysxArticulationLinkComponent]) -> list[ConvexBody]:
    """Every collision shape of ``links`` as a convex body at the links' present poses."""
    bodies = []
    for link in links:
        pose = link.entity_pose.to_transformation_matrix()
        for shape in link.get_collision_shapes():
            points = _shape_points(shape)
            if points is not None:
                bodies.append(_body(points, pose))
    return bodies


def part_bodies(parts: Sequence[trimesh.Trimesh], pose: np.ndarray) -> list[ConvexBody]:
    """An object's convex parts (its frame) as convex bodies at ``pose`` (4, 4, world)."""
    return [_body(np.asarray(part.vertices, float), pose) for part in parts]


def meets(arm: list[ConvexBody], parts: list[ConvexBody], clearance: float) -> bool:
    return any(bodies_meet(a, p, clearance) for a in arm for p in parts)
