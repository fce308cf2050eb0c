"""Procedural object meshes from sampled shape parameters (pure: parameters in, meshes out).

Every shape is a list of convex parts in the object's frame (metres). Collision uses the parts
as convex meshes; the visual mesh is their concatenation, except for the household kinds of
:mod:`datagen.assets.household` (revolved and swept parts: drawn smooth, colliding as their convex
parts). A shape is fully described by its JSON parameters, so a sample's metadata is enough to
rebuild its objects.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

from datagen.assets import household
from datagen.assets.family_names import HOUSEHOLD_FAMILIES


@dataclass(frozen=True)
class ObjectGeometry:
    parts: list[trimesh.Trimesh]  # convex, in the object frame
    visual: trimesh.Trimesh
    obb_transform: np.ndarray  # (4, 4) object frame -> oriented-box frame origin at its centre
    obb_extents: np.ndarray  # (3,) full edge lengths, metres
    # False where the drawn mesh is not the parts' union (smooth household shapes, user meshes)
    visual_is_parts: bool = True


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
    elif kind == "prism":
        mesh = household.prism(p)
    else:
        raise ValueError(f"unknown part kind {kind!r}")
    _place(mesh, p)
    return mesh


def _place(mesh: trimesh.Trimesh, p: dict[str, Any]) -> None:
    """Moves a part to its pose in the object frame (``offset``, ``quat_wxyz``), if it has one."""
    if "offset" in p:
        transform = np.eye(4)
        transform[:3, :3] = trimesh.transformations.quaternion_matrix(p["quat_wxyz"])[:3, :3]
        transform[:3, 3] = p["offset"]
        mesh.apply_transform(transform)


def _visual_and_parts(p: dict[str, Any]) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh]]:
    if p["kind"] not in household.COMPOSITE_KINDS:
        mesh = _part(p["kind"], p)
        return mesh, [mesh]
    visual, parts = household.composite_part(p)
    for mesh in (visual, *parts):
        _place(mesh, p)
    return visual, parts


def build_geometry(shape: dict[str, Any]) -> ObjectGeometry:
    """``shape`` is ``{"family": ..., "parts": [{"kind": ..., **params}, ...]}``. The result is
    shared by every call with equal parameters (a scene samples and builds each shape, several
    exports rebuild it): read it, copy it before changing it."""
    return _cached_geometry(json.dumps(shape, sort_keys=True))


@functools.lru_cache(maxsize=128)
def _cached_geometry(shape_json: str) -> ObjectGeometry:
    shape = json.loads(shape_json)
    built = [_visual_and_parts(p) for p in shape["parts"]]
    parts = [part for _, part_list in built for part in part_list]
    visuals = [visual for visual, _ in built]
    visual = trimesh.util.concatenate(visuals) if len(visuals) > 1 else visuals[0].copy()
    # revolved and swept parts are drawn smooth, their convex parts only approximate them
    visual_is_parts = not any(p["kind"] in household.COMPOSITE_KINDS for p in shape["parts"])
    if "asset" in shape:  # a user's mesh: drawn as itself, collides as its convex parts
        from datagen.assets.mesh_library import load_library

        asset = shape["asset"]
        found = load_library(asset["root"]).find(asset["path"])
        if found is not None:
            visual = found.visual.copy().apply_scale(asset["scale"])
            visual_is_parts = False
    if shape["family"] in ("box", "cylinder", "sphere", "capsule", *HOUSEHOLD_FAMILIES):
        # primitives and household shapes: the box aligned with the object frame is the tight
        # oriented box
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
        parts,
        visual,
        np.asarray(obb_transform, float),
        np.asarray(extents, float),
        visual_is_parts,
    )
