"""The separating-axis test of two convex bodies (pure)."""

from __future__ import annotations

import numpy as np
import trimesh

from datagen.convex import ConvexBody, bodies_meet


def _cube(at, size=1.0, turn_deg=0.0) -> ConvexBody:
    box = trimesh.creation.box(extents=[size] * 3)
    box.apply_transform(trimesh.transformations.rotation_matrix(np.radians(turn_deg), [0, 0, 1]))
    box.apply_translation(at)
    return ConvexBody.from_mesh(box)


def test_bodies_meet_when_they_overlap_or_come_within_the_clearance():
    a = _cube([0, 0, 0])
    assert bodies_meet(a, _cube([0.9, 0, 0]))
    assert not bodies_meet(a, _cube([1.2, 0, 0]))
    assert bodies_meet(a, _cube([1.2, 0, 0]), clearance=0.25)
    # bounds overlap, the bodies do not: a cube turned 45° beside a corner, found by a face axis
    assert not bodies_meet(a, _cube([1.15, 1.15, 0], turn_deg=45))
    assert bodies_meet(a, _cube([0.8, 0.8, 0], turn_deg=45))
