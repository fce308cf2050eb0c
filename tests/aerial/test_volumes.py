"""3-D volumes (datagen/families/aerial/volumes.py): the plan's walls raised, flyer-only solids that never
cut the free space, the voxel grid as documented, box arithmetic."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.families.aerial.volumes import (
    FLYER_KINDS,
    VolumeParams,
    box_distance,
    components,
    free_space,
    make_volume,
    subtract,
    voxelise,
)
from datagen.floorplans.layouts import make_layout

PARAMS = VolumeParams(
    pillars=(2, 3), beams=(1, 2), hanging=(1, 2), screens=(1, 1), window_probability=1.0
)


@pytest.mark.parametrize("family", ["rooms", "corridor", "maze"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_flyer_solids_never_cut_the_free_space(family, seed):
    layout = make_layout(family, np.random.default_rng(seed))
    volume = make_volume(np.random.default_rng(100 + seed), layout, PARAMS)
    walls_only = [s.box for s in volume.solids if s.kind not in FLYER_KINDS]
    plain = components(
        free_space(
            voxelise(walls_only, volume.shape, volume.resolution),
            volume.resolution,
            PARAMS.clearance,
        )
    )
    assert components(free_space(volume.occupancy, volume.resolution, PARAMS.clearance)) <= plain
    kinds = {s.kind for s in volume.solids}
    assert {"wall", "ceiling"} <= kinds and kinds & {"pillar", "beam", "hanging", "screen"}
    assert PARAMS.height[0] <= volume.height <= PARAMS.height[1]
    if family == "rooms" and layout.doors:
        assert volume.params["windows"]  # window_probability 1: an opening beside every door


def test_the_same_rng_gives_the_same_volume():
    layout = make_layout("corridor", np.random.default_rng(5))
    a = make_volume(np.random.default_rng(6), layout, PARAMS)
    b = make_volume(
        np.random.default_rng(6), make_layout("corridor", np.random.default_rng(5)), PARAMS
    )
    assert [s.box for s in a.solids] == [s.box for s in b.solids] and a.params == b.params


def test_voxel_indices_follow_the_documented_frame():
    # a box over x in [0.23, 0.37], y in [0.51, 0.59], z in [1.05, 1.25] with 0.1 m voxels
    grid = voxelise([(0.23, 0.51, 1.05, 0.37, 0.59, 1.25)], (20, 10, 10), 0.1)
    k, i, j = np.nonzero(grid)
    assert sorted(set(k)) == [10, 11, 12] and sorted(set(i)) == [5] and sorted(set(j)) == [2, 3]


def test_the_grid_is_conservative():
    """A voxel a solid touches is occupied: a face on a voxel boundary marks both sides, so every
    point of the box (faces included) lies in an occupied voxel."""
    box = (0.2, 0.5, 1.0, 0.4, 0.6, 1.3)
    grid = voxelise([box], (20, 10, 10), 0.1)
    k, i, j = np.nonzero(grid)
    assert sorted(set(k)) == list(range(9, 14)) and sorted(set(i)) == [4, 5, 6]
    assert sorted(set(j)) == [1, 2, 3, 4]
    points = np.random.default_rng(0).uniform(box[:3], box[3:], (2000, 3))
    points[::2, 0] = box[3]  # on faces
    points[1::4, 2] = box[2]
    cells = np.floor(
        points[:, ::-1] / 0.1 + np.random.default_rng(1).choice([-1e-9, 1e-9], (2000, 3))
    )
    assert grid[tuple(cells.astype(int).T)].all()


def test_box_distance_and_subtraction():
    boxes = np.array([[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]])
    points = np.array([[0.5, 0.5, 0.5], [2.0, 0.5, 0.5], [2.0, 2.0, 0.5]])
    assert np.allclose(box_distance(points, boxes), [0.0, 1.0, np.sqrt(2)])
    pieces = subtract((0.0, 0.0, 0.0, 1.0, 1.0, 1.0), (0.25, -1.0, 0.25, 0.75, 2.0, 0.75))
    volume = sum((b[3] - b[0]) * (b[4] - b[1]) * (b[5] - b[2]) for b in pieces)
    assert volume == pytest.approx(1.0 - 0.25)  # a 0.5 x 1 x 0.5 hole through the box
    grid = voxelise(pieces, (10, 10, 10), 0.1)
    assert not grid[4, 5, 4] and grid[1, 5, 1]  # the hole is open, the rest solid
    assert subtract((0, 0, 0, 1, 1, 1), (2, 2, 2, 3, 3, 3)) == [(0, 0, 0, 1, 1, 1)]
