"""Pure-pursuit path following for a differential-drive (unicycle) robot, simulated kinematically
at a fixed control rate. No dynamics, no slip: the simulator later replays or tracks this. A
command (v, w) held for one control step drives an exact arc (:func:`arc`), so the recorded
commands integrated in closed form give the recorded poses back."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from datagen.families.navigation.planning import footprint_collides
from datagen.floorplans.grid import Layout


@dataclass
class FollowParams:
    lookahead: float = 0.3  # metres along the path ahead of the closest point
    max_linear: float = 0.6  # m/s
    max_angular: float = 1.5  # rad/s
    rate_hz: float = 10.0  # control rate
    goal_tolerance: float = 0.2  # success when the centre is this close to the goal, metres
    turn_in_place: float = math.radians(45)  # heading error above which the robot only rotates
    robot_radius: float = 0.25  # footprint disk for the collision flag, metres
    max_steps: int | None = None  # default: 3x the path at full speed + 20 s


@dataclass
class Trajectory:
    """Per step k: the pose, the command applied from it, and observations at the pose.
    ``poses``, ``distance_to_goal``, ``goal_in_robot`` and ``collision`` have one more row than
    ``commands`` (the final pose)."""

    poses: np.ndarray  # (n+1, 3) x, y, yaw
    commands: np.ndarray  # (n, 2) v (m/s), w (rad/s)
    distance_to_goal: np.ndarray  # (n+1,) metres
    goal_in_robot: np.ndarray  # (n+1, 2) goal in the robot frame (x forward, y left), metres
    collision: np.ndarray  # (n+1,) bool, footprint overlaps an occupied cell
    success: bool
    dt: float

    def to_dict(self) -> dict:
        r = lambda a: np.round(a, 6).tolist()  # noqa: E731
        return {
            "poses": r(self.poses),
            "commands": r(self.commands),
            "distance_to_goal": r(self.distance_to_goal),
            "goal_in_robot": r(self.goal_in_robot),
            "collision": self.collision.tolist(),
            "success": self.success,
            "dt": self.dt,
        }


def wrap_angle(a: float) -> float:
    """``a`` in [-pi, pi) (radians)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


def arc(
    x: float, y: float, heading: float, curvature: float, distance: float
) -> tuple[float, float, float]:
    """The point ``distance`` metres along the circle of ``curvature`` (1/m, positive turns
    left) that leaves (x, y) along ``heading``, and the angle turned on the way (radians)."""
    turned = curvature * distance
    half = turned / 2
    chord = distance * (math.sin(half) / half if abs(half) > 1e-9 else 1.0)  # 2 sin(half) / k
    return x + chord * math.cos(heading + half), y + chord * math.sin(heading + half), turned


def unicycle_step(
    x: float, y: float, yaw: float, v: float, w: float, dt: float
) -> tuple[float, float, float]:
    """The pose after holding (v m/s, w rad/s) for ``dt`` seconds: an exact arc (a turn on the
    spot when v = 0)."""
    if abs(v) < 1e-12:
        return x, y, wrap_angle(yaw + w * dt)
    x, y, turned = arc(x, y, yaw, w / v, v * dt)
    return x, y, wrap_angle(yaw + turned)


def _progress(
    path: np.ndarray, s_cum: np.ndarray, p: np.ndarray, s_prev: float, window: float
) -> float:
    """Arc length of the closest path point to p among those in [s_prev, s_prev + window]."""
    a, b = path[:-1], path[1:]
    seg = b - a
    seg_len2 = np.maximum((seg**2).sum(axis=1), 1e-12)
    t = np.clip(((p - a) * seg).sum(axis=1) / seg_len2, 0.0, 1.0)
    s = s_cum[:-1] + t * np.sqrt(seg_len2)
    d = np.hypot(*(a + t[:, None] * seg - p).T)
    d[(s < s_prev - 1e-9) | (s > s_prev + window)] = np.inf
    return max(s_prev, float(s[np.argmin(d)])) if np.isfinite(d).any() else s_prev


@dataclass
class Recorder:
    """The per-pose rows of a trajectory being driven (the followers share it)."""

    goal: np.ndarray
    radius: float  # metres: footprint disk for the collision flag
    layout: Layout | None
    poses: list = field(default_factory=list)
    dist: list = field(default_factory=list)
    rel: list = field(default_factory=list)
    coll: list = field(default_factory=list)
    cmds: list = field(default_factory=list)

    def observe(self, x: float, y: float, yaw: float) -> float:
        """Records the pose and what is seen from it; returns the distance to the goal."""
        dx, dy = self.goal[0] - x, self.goal[1] - y
        self.poses.append((x, y, yaw))
        self.dist.append(math.hypot(dx, dy))
        self.rel.append(
            (math.cos(yaw) * dx + math.sin(yaw) * dy, -math.sin(yaw) * dx + math.cos(yaw) * dy)
        )
        self.coll.append(
            self.layout is not None
            and footprint_collides(self.layout.grid, self.layout.resolution, x, y, self.radius)
        )
        return self.dist[-1]

    def trajectory(self, success: bool, dt: float) -> Trajectory:
        return Trajectory(
            poses=np.array(self.poses),
            commands=np.array(self.cmds).reshape(-1, 2),
            distance_to_goal=np.array(self.dist),
            goal_in_robot=np.array(self.rel),
            collision=np.array(self.coll, dtype=bool),
            success=success,
            dt=dt,
        )


def lookahead_point(
    path: np.ndarray, s_cum: np.ndarray, s_prev: float, lookahead: float
) -> np.ndarray:
    """The path's point ``lookahead`` metres of arc length past ``s_prev`` (its end at most)."""
    s_target = min(s_prev + lookahead, s_cum[-1])
    return np.array(
        [np.interp(s_target, s_cum, path[:, 0]), np.interp(s_target, s_cum, path[:, 1])]
    )


# one step of a drive: (x, y, yaw, look-ahead point, distance to the goal, dt) -> (command,
# the pose after applying it for dt)
Drive = Callable[
    [float, float, float, np.ndarray, float, float],
    tuple[tuple[float, float], tuple[float, float, float]],
]


def pursue(
    path_world,
    start_yaw: float | None,
    lookahead: float,
    max_linear: float,
    rate_hz: float,
    goal_tolerance: float,
    robot_radius: float,
    drive: Drive,
    layout: Layout | None = None,
    max_steps: int | None = None,
) -> Trajectory:
    """Pure pursuit from the path's first point to its last, heading ``start_yaw`` (None: along
    the first leg) at the start; ``drive`` turns each step's look-ahead point into a command and
    the next pose. Stops at the goal or after ``max_steps`` (default: 3x the path at full speed
    + 20 s)."""
    path = np.asarray(path_world, dtype=float).reshape(-1, 2)
    if len(path) == 1:
        path = np.vstack([path, path])
    s_cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    goal, total, dt = path[-1], s_cum[-1], 1.0 / rate_hz
    max_steps = max_steps or math.ceil((3 * total / max_linear + 20.0) / dt)
    if start_yaw is None:
        first = path[1] - path[0]
        start_yaw = math.atan2(first[1], first[0])
    x, y, yaw = float(path[0, 0]), float(path[0, 1]), float(start_yaw)
    s_prev = 0.0
    rec = Recorder(goal, robot_radius, layout)
    success = False
    while True:
        distance = rec.observe(x, y, yaw)
        if distance <= goal_tolerance:
            success = True
            break
        if len(rec.cmds) >= max_steps:
            break
        s_prev = _progress(path, s_cum, np.array([x, y]), s_prev, 2 * lookahead + 0.5)
        target = lookahead_point(path, s_cum, s_prev, lookahead)
        command, (x, y, yaw) = drive(x, y, yaw, target, distance, dt)
        rec.cmds.append(command)
    return rec.trajectory(success, dt)


def follow(
    path_world, start_yaw: float, params: FollowParams | None = None, layout: Layout | None = None
) -> Trajectory:
    """Drive from the path's first point to its last; collisions are checked against
    ``layout.grid`` (un-inflated) when a layout is given."""
    p = params or FollowParams()

    def unicycle(x, y, yaw, target, distance, dt):
        tdist = max(math.hypot(target[0] - x, target[1] - y), 1e-6)
        alpha = wrap_angle(math.atan2(target[1] - y, target[0] - x) - yaw)
        if abs(alpha) > p.turn_in_place:
            v, w = 0.0, math.copysign(min(p.max_angular, abs(alpha) / dt), alpha)
        else:
            v = min(p.max_linear, max(0.1, distance))  # slow down near the goal
            w = v * 2.0 * math.sin(alpha) / tdist  # pure-pursuit curvature
            if abs(w) > p.max_angular:  # keep the curvature, lower the speed
                v *= p.max_angular / abs(w)
                w = math.copysign(p.max_angular, w)
        return (v, w), unicycle_step(x, y, yaw, v, w, dt)

    return pursue(
        path_world,
        start_yaw,
        p.lookahead,
        p.max_linear,
        p.rate_hz,
        p.goal_tolerance,
        p.robot_radius,
        unicycle,
        layout,
        p.max_steps,
    )
