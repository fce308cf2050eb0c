"""One navigation episode, without the simulator: layout, start and goal, expert path, trajectory.

Random streams (from ``datagen.seeding.sample_rng(seed, index, name)``): ``nav_layout`` for the
floor plan and its clutter, ``nav_task`` for the start, the goal and the start heading.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from datagen.config.sections import NavigationConfig
from datagen.families.navigation.ackermann import CarParams, follow_ackermann
from datagen.families.navigation.follow import FollowParams, Trajectory, follow
from datagen.families.navigation.planning import (
    PlanningError,
    astar,
    draw_start_goal,
    path_to_world,
    shortest_path_length_m,
    smooth_path,
)
from datagen.floorplans.geodesic import lower_bound_grid, shortest_length
from datagen.floorplans.grid import ClutterParams, Layout, inflate
from datagen.floorplans.layouts import make_layout
from datagen.registries import GROUND_ROBOTS, LAYOUTS
from datagen.registry import resolve
from datagen.seeding import sample_rng


@dataclass
class Episode:
    layout: Layout
    start: tuple[float, float, float]  # x, y, yaw (metres, radians)
    goal: tuple[float, float]  # x, y (metres)
    start_cell: tuple[int, int]  # (row, col)
    goal_cell: tuple[int, int]
    inflation: float  # metres: robot radius + planning margin
    grid_path: list[tuple[int, int]]  # 8-connected A* cells on the inflated grid
    path: np.ndarray  # (K, 2) world waypoints after line-of-sight smoothing
    trajectory: Trajectory
    shortest_path_m: float  # no collision-free drive to the goal is shorter (geodesic.py)

    @property
    def astar_length_m(self) -> float:
        return shortest_path_length_m(self.grid_path, self.layout.resolution)

    @property
    def planned_path_m(self) -> float:
        """Length of the smoothed (any-angle) path the expert follows."""
        return float(np.hypot(*np.diff(self.path, axis=0).T).sum()) if len(self.path) > 1 else 0.0

    @property
    def travelled_m(self) -> float:
        poses = self.trajectory.poses[:, :2]
        return float(np.hypot(*np.diff(poses, axis=0).T).sum())


def layout_params(cfg: NavigationConfig):
    """The family's layout parameters with the config's clutter settings."""
    params_cls = resolve(LAYOUTS[cfg.family].params)
    family_default = params_cls().clutter
    clutter = ClutterParams(
        count=(cfg.clutter[0], cfg.clutter[1]) if cfg.clutter is not None else family_default.count,
        size=(cfg.clutter_size[0], cfg.clutter_size[1]),
        clearance=cfg.robot_radius + cfg.planning_margin,
    )
    return dataclasses.replace(params_cls(), clutter=clutter)


def follow_params(cfg: NavigationConfig) -> FollowParams:
    return FollowParams(
        lookahead=cfg.lookahead,
        max_linear=cfg.max_linear,
        max_angular=cfg.max_angular,
        rate_hz=cfg.control_rate_hz,
        robot_radius=cfg.robot_radius,
    )


LAYOUT_ATTEMPTS = 10


def layout_attempts(
    cfg: NavigationConfig, seed: int, index: int, retry: int = 0
) -> Iterator[tuple[Layout, np.random.Generator]]:
    """The ``LAYOUT_ATTEMPTS`` layouts an episode may draw, each with the rng of its tasks
    (streams ``nav_layout``/``nav_task``, then ``nav_layout/1``/``nav_task/1``, ...: still a
    function of (seed, index) alone)."""
    for attempt in range(LAYOUT_ATTEMPTS):
        suffix = f"/{attempt}" if attempt else ""
        layout = make_layout(
            cfg.family, sample_rng(seed, index, "nav_layout" + suffix, retry), layout_params(cfg)
        )
        layout.params["attempt"] = attempt
        yield layout, sample_rng(seed, index, "nav_task" + suffix, retry)


def plan_episode(cfg: NavigationConfig, seed: int, index: int, retry: int = 0) -> Episode:
    """Draws a layout and a task until one has a start/goal pair with a path
    (:func:`layout_attempts`). Raises :class:`PlanningError` after ``LAYOUT_ATTEMPTS`` layouts."""
    reasons = []
    for layout, rng in layout_attempts(cfg, seed, index, retry):
        try:
            return plan_task(cfg, layout, rng)
        except PlanningError as exc:
            reasons.append(str(exc))
    raise PlanningError(
        f"episode {index}: no {cfg.family} layout out of {LAYOUT_ATTEMPTS} had a start and goal "
        f"navigation.min_goal_distance={cfg.min_goal_distance} m apart with a path for "
        f"navigation.robot_radius + planning_margin; lower those or navigation.clutter "
        f"(last reason: {reasons[-1]})"
    )


# A car in footprint radii: its body is 1.6 x 1.0, centred on the footprint disk (its half
# diagonal, 0.94, fits inside); the rear axle is CAR_REAR behind that centre, the front axle
# CAR_WHEELBASE ahead of the rear one.
CAR_WHEELBASE, CAR_REAR = 1.04, 0.5


def car_params(cfg: NavigationConfig) -> CarParams:
    r = cfg.robot_radius
    return CarParams(
        wheelbase=CAR_WHEELBASE * r,
        max_steer=math.radians(cfg.max_steering_deg),
        rear=CAR_REAR * r,
        lookahead=cfg.lookahead,
        max_linear=cfg.max_linear,
        rate_hz=cfg.control_rate_hz,
        robot_radius=r,
    )


def differential_drive(
    cfg: NavigationConfig, path: np.ndarray, yaw: float, layout: Layout
) -> tuple[Trajectory, float, FollowParams]:
    """Fetch's expert: pure pursuit from the drawn heading ``yaw`` (it turns on the spot)."""
    params = follow_params(cfg)
    return follow(path, yaw, params, layout), yaw, params


def ackermann_drive(
    cfg: NavigationConfig, path: np.ndarray, yaw: float, layout: Layout
) -> tuple[Trajectory, float, CarParams]:
    """The car's expert: a car cannot turn on the spot, so it starts along the path (the drawn
    heading is not used)."""
    params = car_params(cfg)
    trajectory = follow_ackermann(path, params, layout)
    return trajectory, float(trajectory.poses[0, 2]), params


def _arm_ends(rng: np.random.Generator, layout: Layout) -> tuple[tuple[int, int], tuple[int, int]]:
    """A start and a goal at the ends of two different arms of a plus maze (cells)."""
    ends = layout.params["arm_ends"]
    a, b = rng.choice(len(ends), size=2, replace=False)
    cell = lambda p: (int(p[1] / layout.resolution), int(p[0] / layout.resolution))  # noqa: E731
    return cell(ends[a]), cell(ends[b])


def plan_task(
    cfg: NavigationConfig, layout: Layout, rng: np.random.Generator, taken: np.ndarray | None = None
) -> Episode:
    """A start, a goal, the expert's path and trajectory in ``layout``; with ``taken`` (a bool
    grid of the layout's shape), start and goal are drawn where it is False (several robots:
    away from the others' starts and goals), the path planned in the layout itself."""
    inflation = cfg.robot_radius + cfg.planning_margin
    if "arm_ends" in layout.params and taken is None:  # the four-arm maze: arm end to arm end
        start, goal = _arm_ends(rng, layout)
    else:
        drawn_in = (
            layout if taken is None else dataclasses.replace(layout, grid=layout.grid | taken)
        )
        start, goal = draw_start_goal(rng, drawn_in, inflation, cfg.min_goal_distance)
    occupied = inflate(layout.grid, inflation, layout.resolution)
    cells = astar(occupied, start, goal)
    if cells is None:  # draw_start_goal only returns connected pairs
        raise PlanningError(f"A* found no path from {start} to {goal} in a connected component")
    path = path_to_world(smooth_path(occupied, cells), layout.resolution)
    yaw = float(rng.uniform(-math.pi, math.pi))
    drive = resolve(GROUND_ROBOTS[cfg.robot].drive)
    trajectory, yaw, params = drive(cfg, path, yaw, layout)
    start_xy, goal_xy = path[0], path[-1]
    step = params.max_linear / params.rate_hz  # metres: the longest move between two poses
    lower = lower_bound_grid(layout.grid, layout.resolution, cfg.robot_radius, step)
    geodesic = shortest_length(lower, layout.resolution, tuple(start_xy), tuple(goal_xy))
    return Episode(
        layout=layout,
        start=(float(start_xy[0]), float(start_xy[1]), yaw),
        goal=(float(goal_xy[0]), float(goal_xy[1])),
        start_cell=start,
        goal_cell=goal,
        inflation=inflation,
        grid_path=cells,
        path=path,
        trajectory=trajectory,
        shortest_path_m=max(geodesic - params.goal_tolerance, 0.0),
    )


def frame_steps(trajectory: Trajectory, frame_rate_hz: float) -> list[int]:
    """Control steps at which frames are rendered: every 1/frame_rate seconds from step 0, and
    always the final pose."""
    last = len(trajectory.poses) - 1
    every = frame_rate_hz * trajectory.dt
    steps = sorted({min(last, round(k / every)) for k in range(int(last * every) + 1)} | {last})
    return steps
