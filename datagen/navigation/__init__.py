"""Simulator-free core of the navigation scenes: seeded occupancy-grid layouts, grid planning
and a differential-drive path follower. Nothing here imports SAPIEN.

Conventions (all modules): an occupancy grid is a 2-D numpy bool array, True = occupied, indexed
``grid[row, col]``; world x runs along columns and y along rows; the world origin (0, 0) is the
outer corner of cell (0, 0), so cell (r, c) covers x in [c*res, (c+1)*res) and y in
[r*res, (r+1)*res), with its centre at ((c+0.5)*res, (r+0.5)*res). Rectangles are
(x0, y0, x1, y1) in world metres; yaw is in radians from +x towards +y.
"""

from datagen.navigation.follow import FollowParams, Trajectory, follow
from datagen.navigation.grid import ClutterParams, Layout, add_clutter, inflate
from datagen.navigation.layouts import (
    CorridorParams,
    MazeParams,
    RoomsParams,
    corridor,
    make_layout,
    maze,
    rooms,
)
from datagen.navigation.planning import (
    PlanningError,
    astar,
    draw_start_goal,
    footprint_collides,
    path_to_world,
    shortest_path_length_m,
    smooth_path,
)

__all__ = [
    "ClutterParams",
    "CorridorParams",
    "FollowParams",
    "Layout",
    "MazeParams",
    "PlanningError",
    "RoomsParams",
    "Trajectory",
    "add_clutter",
    "astar",
    "corridor",
    "draw_start_goal",
    "follow",
    "footprint_collides",
    "inflate",
    "make_layout",
    "maze",
    "path_to_world",
    "rooms",
    "shortest_path_length_m",
    "smooth_path",
]
