"""Household-like shapes (datagen/assets/household.py, datagen/randomisers/household_parts.py): rebuilt
byte for byte from their stored parameters, convex parts that are really convex and fill the
smooth visual mesh, and every family settling in the tray of a real SAPIEN scene."""

from __future__ import annotations

import json

import numpy as np
import pytest
import sapien

from datagen.assets import family_names, household
from datagen.assets.shapes import _cached_geometry, build_geometry
from datagen.assets.tabletop_layout import TRAY_CENTRE, TRAY_FLOOR, TRAY_INNER_HALF
from datagen.config import BuildConfig
from datagen.config.appearance import DistractorsConfig
from datagen.config.sections import HOUSEHOLD_FAMILIES, SHAPE_FAMILIES, ObjectsConfig, RenderConfig
from datagen.randomisers.objects import draw_shape

SEEDS = range(4)


def _shape(family: str, seed: int, size: float = 0.08) -> dict:
    return draw_shape(np.random.default_rng(seed), family, size)


def _mesh_bytes(mesh) -> bytes:
    return np.asarray(mesh.vertices).tobytes() + np.asarray(mesh.faces).tobytes()


def test_household_families_are_shape_families():
    assert HOUSEHOLD_FAMILIES is family_names.HOUSEHOLD_FAMILIES  # one tuple, imported
    assert set(HOUSEHOLD_FAMILIES) <= set(SHAPE_FAMILIES)
    assert ObjectsConfig().families == SHAPE_FAMILIES  # the default draws from all of them


@pytest.mark.parametrize("family", HOUSEHOLD_FAMILIES)
def test_same_parameters_rebuild_the_same_mesh_bytes(family):
    for seed in SEEDS:
        shape = _shape(family, seed)
        assert shape == _shape(family, seed)
        stored = json.loads(json.dumps(shape))  # as it comes back from the metadata
        a = build_geometry(shape)
        _cached_geometry.cache_clear()  # built again, not the shared copy
        b = build_geometry(stored)
        assert a is not b
        assert _mesh_bytes(a.visual) == _mesh_bytes(b.visual)
        assert [_mesh_bytes(p) for p in a.parts] == [_mesh_bytes(p) for p in b.parts]
        assert np.array_equal(a.obb_extents, b.obb_extents)
    assert _shape(family, 0) != _shape(family, 1)


def _winding_numbers(mesh, points: np.ndarray) -> np.ndarray:
    """Generalised winding number of each point (1 inside a closed outward-facing surface, 0
    outside, summed over overlapping components): the triangles' solid angles over 4 pi."""
    a, b, c = (mesh.triangles[None, :, k] - points[:, None] for k in range(3))
    la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
    numerator = np.einsum("pfk,pfk->pf", a, np.cross(b, c))
    denominator = (
        la * lb * lc
        + np.einsum("pfk,pfk->pf", a, b) * lc
        + np.einsum("pfk,pfk->pf", a, c) * lb
        + np.einsum("pfk,pfk->pf", b, c) * la
    )
    return (2 * np.arctan2(numerator, denominator)).sum(axis=1) / (4 * np.pi)


def _inside_convex(part, points: np.ndarray, tolerance: float = 1e-7) -> np.ndarray:
    """Which points lie in the convex mesh (on the inner side of every face plane)."""
    normals, origins = part.face_normals, part.triangles[:, 0]
    distances = np.einsum("fk,pk->pf", normals, points) - np.einsum("fk,fk->f", normals, origins)
    return (distances <= tolerance).all(axis=1)


@pytest.mark.parametrize("family", HOUSEHOLD_FAMILIES)
def test_convex_parts_are_convex_and_fill_the_visual_mesh(family):
    rng = np.random.default_rng(0)
    for seed in SEEDS:
        geometry = build_geometry(_shape(family, seed))
        visual = geometry.visual
        for part in geometry.parts:
            assert part.is_convex and part.is_watertight and part.volume > 0, family
        assert visual.is_watertight and visual.volume > 0
        # points of the smooth solid are in some convex part (the parts cover it) ...
        lo, hi = visual.bounds
        points = rng.uniform(lo, hi, size=(1500, 3))
        inside_visual = points[_winding_numbers(visual, points) > 0.5]
        assert len(inside_visual) > 50
        covered = np.zeros(len(inside_visual), bool)
        for part in geometry.parts:
            covered |= _inside_convex(part, inside_visual, tolerance=1e-6)
        assert covered.mean() > 0.99, (family, seed, covered.mean())
        # ... and the parts hold little more than the solid (circumscribed walls, overlaps)
        parts_volume = sum(part.volume for part in geometry.parts)
        assert visual.volume * 0.999 <= parts_volume <= visual.volume * 1.4, family


@pytest.mark.parametrize("family", HOUSEHOLD_FAMILIES)
def test_largest_extent_follows_the_size(family):
    for seed in SEEDS:
        for size in (0.045, 0.1):
            extent = float(np.max(build_geometry(_shape(family, seed, size)).obb_extents))
            assert 0.7 * size <= extent <= 1.05 * size, (family, size, extent)


def test_solids_of_revolution_are_exactly_their_frusta():
    geometry = build_geometry(_shape("bottle", 0))
    assert not geometry.visual_is_parts
    assert sum(p.volume for p in geometry.parts) == pytest.approx(geometry.visual.volume, 1e-9)
    assert build_geometry(_shape("lidded_box", 0)).visual_is_parts  # prisms: drawn as parts


@pytest.mark.parametrize(
    "spec",
    [
        {"kind": "revolve", "profile": [[0.01, 0.0]]},
        {"kind": "revolve", "profile": [[0.01, 0.1], [0.01, 0.0]]},
        {
            "kind": "shell",
            "profile": [[-0.01, 0.0], [0.02, 0.05]],
            "thickness": 0.003,
            "base": 0.003,
        },
    ],
)
def test_a_malformed_profile_is_refused_by_name(spec):
    with pytest.raises(ValueError, match=f"{spec['kind']} profile: expected"):
        household.composite_part(spec)


@pytest.mark.sim
@pytest.mark.parametrize("family", HOUSEHOLD_FAMILIES)
def test_every_household_family_settles_and_stays_in_the_tray(family):
    from datagen.families.grasp_tabletop.world import build_scene

    config = BuildConfig(
        objects=ObjectsConfig(count=(3, 3), families=(family,)),
        distractors=DistractorsConfig(enabled=False),
        render=RenderConfig(width=64, height=48),
    )
    scene = build_scene(config, seed=3, index=0)
    settled = [np.array(o.entity.pose.p) for o in scene.objects]
    for _ in range(100):  # half a second more: a stable rest does not creep
        scene.scene.step()
    for obj, before in zip(scene.objects, settled, strict=True):
        body = obj.entity.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        x, y, z = obj.entity.pose.p
        assert abs(x - TRAY_CENTRE[0]) < TRAY_INNER_HALF[0], family
        assert abs(y - TRAY_CENTRE[1]) < TRAY_INNER_HALF[1], family
        assert z > TRAY_CENTRE[2] + TRAY_FLOOR - 1e-3, family  # above the floor, not through it
        assert np.linalg.norm(obj.entity.pose.p - before) < 0.005, family
        assert np.linalg.norm(body.linear_velocity) < 0.05, family
