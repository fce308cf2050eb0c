"""The shortest path any robot can drive (datagen/floorplans/geodesic.py), against closed forms:
an empty room, a wall to go round, a closed door; and never longer than a collision-free path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from datagen.floorplans.geodesic import convex_corners, lower_bound_grid, shortest_length


def test_an_empty_room_gives_the_straight_line():
    grid = np.zeros((40, 60), bool)
    assert shortest_length(grid, 0.1, (0.5, 0.5), (5.5, 3.5)) == pytest.approx(math.hypot(5.0, 3.0))


def test_round_a_wall_the_path_bends_at_its_corner():
    grid = np.zeros((40, 40), bool)
    grid[0:30, 20] = True  # a wall from the bottom up to y = 3.0 m at x = 2.0..2.1 m
    start, goal = (1.0, 1.0), (3.0, 1.0)
    # round the wall's top: to the corner (2.0, 3.0), across its top to (2.1, 3.0), down
    expected = math.hypot(1.0, 2.0) + 0.1 + math.hypot(0.9, 2.0)
    assert shortest_length(grid, 0.1, start, goal) == pytest.approx(expected, abs=1e-9)


def test_a_closed_room_cannot_be_left():
    grid = np.zeros((20, 20), bool)
    grid[5, 5:15] = grid[14, 5:15] = grid[5:15, 5] = grid[5:15, 14] = True
    assert shortest_length(grid, 0.1, (1.0, 1.0), (1.0, 1.0)) == 0.0
    assert math.isinf(shortest_length(grid, 0.1, (0.2, 0.2), (1.0, 1.0)))


def test_corners_are_where_one_of_four_cells_is_occupied():
    grid = np.zeros((5, 5), bool)
    grid[2, 2] = True
    assert sorted(map(tuple, convex_corners(grid))) == [
        (2.0, 2.0),
        (2.0, 3.0),
        (3.0, 2.0),
        (3.0, 3.0),
    ]


@pytest.mark.parametrize("seed", range(5))
def test_no_collision_free_walk_is_shorter(seed):
    """Random walks of a disk that never touches a wall, from the start to the goal's cell."""
    rng = np.random.default_rng(seed)
    grid = rng.random((30, 30)) < 0.08
    res, radius, step = 0.1, 0.12, 0.02
    occupied = lower_bound_grid(grid, res, radius, step)
    cells = np.argwhere(~grid)
    for _ in range(20):
        walk = [cells[rng.integers(len(cells))][::-1] * res + res / 2]
        length = 0.0
        for _ in range(300):
            nxt = walk[-1] + rng.normal(0, step / 2, 2)
            if np.linalg.norm(nxt - walk[-1]) > step:
                continue
            x, y = nxt
            c0, c1 = int((x - radius) / res), int((x + radius) / res) + 1
            r0, r1 = int((y - radius) / res), int((y + radius) / res) + 1
            if min(r0, c0) < 0 or r1 > 30 or c1 > 30:
                continue
            r, c = np.nonzero(grid[r0:r1, c0:c1])
            px = np.clip(x, (c + c0) * res, (c + c0 + 1) * res)
            py = np.clip(y, (r + r0) * res, (r + r0 + 1) * res)
            if (np.hypot(px - x, py - y) < radius).any():
                continue  # the disk would touch an occupied cell
            length += float(np.linalg.norm(nxt - walk[-1]))
            walk.append(nxt)
        if len(walk) > 1:
            bound = shortest_length(occupied, res, tuple(walk[0]), tuple(walk[-1]))
            assert bound <= length + 1e-9
