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


def test_a_mesh_that_is_not_convex_is_taken_as_its_convex_hull():
    """An L of two boxes: a box in its notch misses the mesh but is inside its hull, and the
    body the tests use is the hull (conservative), edges included."""
    from datagen.convex import box_hits_body

    upright = trimesh.creation.box(extents=[0.2, 0.2, 1.0])
    upright.apply_translation([0.0, 0.0, 0.5])
    foot = trimesh.creation.box(extents=[1.0, 0.2, 0.2])
    foot.apply_translation([0.5, 0.0, 0.1])
    ell = trimesh.util.concatenate([upright, foot])
    assert not ell.is_convex
    body = ConvexBody.from_mesh(ell)
    assert len(body.vertices) == len(ell.convex_hull.vertices)
    in_notch = np.eye(4)
    in_notch[:3, 3] = [0.3, 0.0, 0.3]  # above the foot, beside the upright, under the hull's slope
    assert box_hits_body(in_notch, np.full(3, 0.05), body)
    far = in_notch.copy()
    far[:3, 3] = [0.8, 0.0, 0.8]  # beyond the slope from the foot's tip to the upright's top
    assert not box_hits_body(far, np.full(3, 0.05), body)
