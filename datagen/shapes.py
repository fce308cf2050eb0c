"""Procedural object meshes from sampled shape parameters (pure: parameters in, meshes out).

Every shape is a list of convex parts in the object's frame (metres). Collision uses the parts
as convex meshes; the visual mesh is their concatenation. A shape is fully described by its
JSON parameters, so a sample's metadata is enough to rebuild its objects.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh


@dataclass(frozen=True)
class ObjectGeometry:
    parts: list[trimesh.Trimesh]  # convex, in the object frame
    visual: trimesh.Trimesh
    obb_transform: np.ndarray  # (4, 4) object frame -> oriented-box frame origin at its centre
    obb_extents: np.ndarray  # (3,) full edge lengths, metres


def _part(kind: str, p: dict[str, Any]) -> trimesh.Trimesh:
    if kind == "box":
        mesh = trimesh.creation.box(extents=p["extents"])
    elif kind == "cylinder":
        mesh = trimesh.creation.cylinder(radius=p["radius"], height=p["height"], sections=32)
    elif kind == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=p["radius"])
    elif kind == "capsule":
        mesh = trimesh.creation.capsule(height=p["height"], radius=p["radius"], count=[16, 16])
    elif kind == "convex":
        mesh = trimesh.convex.convex_hull(np.asarray(p["points"], dtype=np.float64))
    else:
        raise ValueError(f"unknown part kind {kind!r}")
    if "offset" in p:
        transform = np.eye(4)
        transform[:3, :3] = trimesh.transformations.quaternion_matrix(p["quat_wxyz"])[:3, :3]
        transform[:3, 3] = p["offset"]
        mesh.apply_transform(transform)
    return mesh


def build_geometry(shape: dict[str, Any]) -> ObjectGeometry:
    """``shape`` is ``{"family": ..., "parts": [{"kind": ..., **params}, ...]}``."""
    parts = [_part(p["kind"], p) for p in shape["parts"]]
    visual = trimesh.util.concatenate(parts) if len(parts) > 1 else parts[0].copy()
    if "asset" in shape:  # a user's mesh: drawn as itself, collides as its convex parts
        from datagen.mesh_library import load_library

        asset = shape["asset"]
        found = load_library(asset["root"]).find(asset["path"])
        if found is not None:
            visual = found.visual.copy().apply_scale(asset["scale"])
    if shape["family"] in ("box", "cylinder", "sphere", "capsule"):
        # primitives: the box aligned with the object frame is the tight oriented box
        lo, hi = visual.bounds
        obb_transform = np.eye(4)
        obb_transform[:3, 3] = (lo + hi) / 2
        extents = hi - lo
    else:
        obb = visual.bounding_box_oriented
        obb_transform, extents = (
            np.asarray(obb.primitive.transform),
            np.asarray(obb.primitive.extents),
        )
    return ObjectGeometry(
        parts, visual, np.asarray(obb_transform, float), np.asarray(extents, float)
    )
