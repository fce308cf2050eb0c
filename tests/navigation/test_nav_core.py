"""Simulator-free navigation core: layouts, planning and path following (fast)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from datagen.families.navigation.follow import follow
from datagen.families.navigation.planning import (
    PlanningError,
    astar,
    draw_start_goal,
    footprint_collides,
    path_to_world,
    shortest_path_length_m,
    smooth_path,
)
from datagen.floorplans.grid import Layout, free_components, inflate
from datagen.floorplans.layouts import make_layout
from datagen.registries import LAYOUTS
from datagen.seeding import sample_rng

ROBOT, CLEARANCE = 0.25, 0.35  # robot radius; planning inflation = radius + 0.1 m margin
SEEDS = range(20)


def episode(family: str, seed: int):
    layout = make_layout(family, sample_rng(seed, 0, "nav_layout"))
    start, goal = draw_start_goal(sample_rng(seed, 0, "nav_task"), layout, CLEARANCE, 2.0)
    occupied = inflate(layout.grid, CLEARANCE, layout.resolution)
    cells = astar(occupied, start, goal)
    yaw = float(sample_rng(seed, 0, "nav_yaw").uniform(-math.pi, math.pi))
    path = path_to_world(smooth_path(occupied, cells), layout.resolution)
    return layout, start, goal, occupied, cells, follow(path, yaw, layout=layout)


@pytest.fixture(scope="module")
def episodes():
    return {(f, s): episode(f, s) for f in LAYOUTS for s in SEEDS}


@pytest.mark.parametrize("family", sorted(LAYOUTS))
def test_layouts_connected_and_described(family, episodes):
    for seed in SEEDS:
        layout = episodes[family, seed][0]
        assert layout.family == family and layout.grid.dtype == bool
        assert free_components(layout.grid, 0.0, layout.resolution) == 1, seed
        clutter = layout.params["clutter"]
        assert clutter["components_after"] <= clutter["components_before"], seed
        inflated = ~inflate(layout.grid, CLEARANCE, layout.resolution)
        sizes = np.bincount(ndimage.label(inflated)[0].ravel())[1:]
        assert sizes.max() >= 0.99 * sizes.sum(), seed  # at most slivers at stepped corners
        assert clutter["placed"] == len(layout.obstacles)
        assert clutter["placed"] + clutter["dropped"] == clutter["requested"]
        walls = np.zeros_like(layout.grid)  # walls + obstacles rebuild the grid exactly
        for x0, y0, x1, y1 in layout.walls + layout.obstacles:
            walls[round(y0 / 0.05) : round(y1 / 0.05), round(x0 / 0.05) : round(x1 / 0.05)] = True
        assert (walls == layout.grid).all(), seed
        assert layout.grid[0].all() and layout.grid[-1].all(), "outer wall"
    if family == "rooms":
        doors = [episodes[family, s][0].doors for s in SEEDS]
        assert all(1 <= len(d) <= 3 for d in doors)
        widths = [max(d[2] - d[0], d[3] - d[1]) for ds in doors for d in ds]
        assert min(widths) >= 0.9 and max(widths) <= 1.2


@pytest.mark.parametrize("family", sorted(LAYOUTS))
def test_paths_and_following(family, episodes):
    for seed in SEEDS:
        layout, start, goal, occupied, cells, traj = episodes[family, seed]
        assert cells is not None and cells[0] == start and cells[-1] == goal
        assert not any(occupied[c] for c in cells)
        steps = np.abs(np.diff(np.array(cells), axis=0))
        assert steps.max() == 1 and steps.sum(axis=1).min() >= 1
        straight = math.dist(start, goal) * layout.resolution
        assert shortest_path_length_m(cells, layout.resolution) >= straight - 1e-9
        assert straight >= 2.0
        assert traj.success, (family, seed)
        assert not traj.collision.any(), (family, seed, np.flatnonzero(traj.collision))
        assert traj.distance_to_goal[-1] <= 0.2
        assert np.abs(traj.commands[:, 0]).max() <= 0.6 + 1e-9
        assert np.abs(traj.commands[:, 1]).max() <= 1.5 + 1e-9
        # goal in the robot frame, rotated back, is the world offset
        x, y, yaw = traj.poses[0]
        gx, gy = traj.goal_in_robot[0]
        world = (
            x + gx * math.cos(yaw) - gy * math.sin(yaw),
            y + gx * math.sin(yaw) + gy * math.cos(yaw),
        )
        assert np.allclose(world, path_to_world([goal], layout.resolution)[0])


@pytest.mark.parametrize("family", sorted(LAYOUTS))
def test_reproducible_and_seed_dependent(family, episodes):
    again = episode(family, 3)
    first = episodes[family, 3]
    assert (again[0].grid == first[0].grid).all()
    assert again[0].params == first[0].params and again[0].walls == first[0].walls
    assert np.array_equal(again[5].poses, first[5].poses)
    assert np.array_equal(again[5].commands, first[5].commands)
    grids = {
        episodes[family, s][0].grid.tobytes() + bytes(episodes[family, s][0].grid.shape)
        for s in SEEDS
    }
    assert len(grids) == len(SEEDS)


def test_astar_hand_computed():
    free = np.zeros((3, 3), bool)
    assert shortest_path_length_m(astar(free, (0, 0), (2, 2)), 1.0) == pytest.approx(
        2 * math.sqrt(2)
    )
    wall = np.zeros((5, 5), bool)
    wall[0:4, 2] = True  # go round the wall's end; no diagonal step past its corner
    path = astar(wall, (0, 0), (0, 4))
    assert (4, 1) in path and (4, 2) in path and (4, 3) in path
    assert shortest_path_length_m(path, 0.1) == pytest.approx(0.1 * (8 + 2 * math.sqrt(2)))
    wall[4, 2] = True
    assert astar(wall, (0, 0), (0, 4)) is None


def test_inflation_and_footprint():
    grid = np.zeros((21, 21), bool)
    grid[10, 10] = True  # one occupied cell, centre (1.05, 1.05) at 0.1 m
    inflated = inflate(grid, 0.25, 0.1)
    assert inflated[10, 12] and not inflated[10, 13]  # edge 0.15 m vs 0.25 m away
    assert inflated[0].all()  # outside the grid counts as occupied
    assert footprint_collides(grid, 0.1, 1.05 + 0.29, 1.05, 0.25)
    assert not footprint_collides(grid, 0.1, 1.05 + 0.31, 1.05, 0.25)


def test_start_goal_failure_is_explicit():
    grid = np.ones((20, 20), bool)
    grid[5:15, 5:15] = False  # 0.5 m free square
    layout = Layout(grid=grid, resolution=0.05, family="tiny", walls=[])
    with pytest.raises(PlanningError, match="after 5 tries"):
        draw_start_goal(np.random.default_rng(0), layout, 0.1, 2.0, max_tries=5)
