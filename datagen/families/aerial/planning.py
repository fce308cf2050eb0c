"""An expert flight through a volume: a path on the inflated voxel grid, pulled taut, then a
minimum-snap trajectory through it, slowed until the quadrotor's limits hold, checked against
the solids themselves.

1. **Path**: Dijkstra over the 26-connected voxels whose centres keep ``radius + margin`` from
   every solid (:func:`datagen.families.aerial.volumes.free_space`), then string pulling: a waypoint is
   dropped while the straight segment that skips it keeps that clearance from every box
   (:func:`datagen.families.aerial.volumes.box_distance`, sampled every ``CHECK_STEP`` metres).
2. **Trajectory**: minimum snap through the waypoints (:mod:`datagen.families.aerial.minsnap`), piece
   times from a velocity ramp. Sampled every ``SAMPLE_DT`` seconds, a piece passing closer than
   ``radius + margin / 2`` to a box gets the midpoint of its straight leg as a new waypoint (the
   pieces then hug the legs), up to ``MAX_SPLITS`` times.
3. **Limits**: all times are scaled by 1.1 until speed, collective thrust (between its least and
   most) and body rates hold at every sample (:mod:`datagen.families.aerial.flatness`). Yaw follows each
   leg's heading, smoothed by minimum snap over the same piece times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from datagen.families.aerial.flatness import FlatStates, flat_states
from datagen.families.aerial.minsnap import PiecewisePolynomial, minimum_snap, ramp_times
from datagen.families.aerial.volumes import Volume, box_distance, free_space

CHECK_STEP = 0.02  # metres between checked points of a straight segment
SAMPLE_DT = 0.01  # seconds between checked points of a trajectory
MAX_SPLITS = 24  # midpoints a trajectory may gain before the flight is given up
SLOW_DOWN = 1.1  # time scaling per round until the limits hold
MAX_SLOW_DOWN = 60  # rounds


class FlightError(RuntimeError):
    """No flight between the drawn points (no path, or no trajectory within the limits)."""


@dataclass(frozen=True)
class FlightLimits:
    radius: float  # metres: the drone's bounding sphere
    margin: float = 0.15  # metres kept beyond the radius when planning
    max_speed: float = 2.0  # m/s
    max_acceleration: float = 3.0  # m/s², for the initial piece times
    max_thrust: float = 20.0  # m/s², mass-normalised collective thrust
    min_thrust: float = 4.0  # m/s²: never near free fall
    max_body_rate: float = 3.0  # rad/s

    @property
    def clearance(self) -> float:
        """Metres a planned path keeps from every solid."""
        return self.radius + self.margin

    @property
    def trajectory_clearance(self) -> float:
        """Metres the flown trajectory keeps from every solid."""
        return self.radius + self.margin / 2


@dataclass(frozen=True)
class Flight:
    waypoints: np.ndarray  # (K, 3) metres, start to goal
    path: PiecewisePolynomial  # position, 3 axes
    yaw: PiecewisePolynomial  # heading, radians, 1 axis, the same piece times
    slow_down: float  # the factor the ramp times were scaled by
    splits: int  # midpoints added for clearance

    @property
    def duration(self) -> float:
        return self.path.duration

    def states(self, time: np.ndarray) -> FlatStates:
        """States at ``time`` seconds from take-off (clipped to the flight: at rest before and
        after)."""
        return flat_states(self.path, self.yaw, np.clip(time, 0.0, self.duration))


def voxel_centre(index: tuple[int, int, int] | np.ndarray, resolution: float) -> np.ndarray:
    """World (x, y, z) of voxel (k, i, j)."""
    k, i, j = np.asarray(index, float)
    return np.array([(j + 0.5) * resolution, (i + 0.5) * resolution, (k + 0.5) * resolution])


def voxel_path(free: np.ndarray, start: tuple, goal: tuple) -> list[tuple[int, int, int]]:
    """Shortest 26-connected chain of free voxels from ``start`` to ``goal`` (k, i, j); empty
    when none."""
    ids = -np.ones(free.shape, np.int64)
    cells = np.argwhere(free)
    ids[tuple(cells.T)] = np.arange(len(cells))
    rows, cols, weights = [], [], []
    for dk, di, dj in ((a, b, c) for a in (0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)):
        if (dk, di, dj) <= (0, 0, 0):
            continue  # each of the 13 directions once
        shifted = cells + np.array([dk, di, dj])
        inside = np.all((shifted >= 0) & (shifted < free.shape), axis=1)
        a, b = cells[inside], shifted[inside]
        ok = free[tuple(b.T)]
        rows.append(ids[tuple(a[ok].T)])
        cols.append(ids[tuple(b[ok].T)])
        weights.append(np.full(ok.sum(), math.sqrt(dk * dk + di * di + dj * dj)))
    n = len(cells)
    graph = coo_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), (n, n)
    )
    source, target = ids[start], ids[goal]
    if source < 0 or target < 0:
        return []
    distance, parent = dijkstra(
        graph.tocsr(), directed=False, indices=source, return_predecessors=True
    )
    if not np.isfinite(distance[target]):
        return []
    chain = [target]
    while chain[-1] != source:
        chain.append(parent[chain[-1]])
    return [(int(cells[i][0]), int(cells[i][1]), int(cells[i][2])) for i in chain[::-1]]


def segment_clear(a: np.ndarray, b: np.ndarray, boxes: np.ndarray, clearance: float) -> bool:
    """True when every point of segment a-b (sampled every ``CHECK_STEP``) keeps ``clearance``
    metres from every box."""
    n = max(math.ceil(float(np.linalg.norm(b - a)) / CHECK_STEP), 1)
    points = a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a)
    return bool(box_distance(points, boxes).min() >= clearance)


def pulled_taut(points: np.ndarray, boxes: np.ndarray, clearance: float) -> np.ndarray:
    """String pulling: from each kept point, the farthest later point reachable in a straight
    line with ``clearance``."""
    kept, i = [0], 0
    while i < len(points) - 1:
        j = len(points) - 1
        while j > i + 1 and not segment_clear(points[i], points[j], boxes, clearance):
            j -= 1
        kept.append(j)
        i = j
    return points[kept]


def _headings(waypoints: np.ndarray) -> np.ndarray:
    """(K,) unwrapped yaw at each waypoint: the heading of the leg leaving it (the last: of the
    leg arriving); a vertical leg keeps the heading before it (the first: the one after)."""
    legs = np.diff(waypoints[:, :2], axis=0)
    defined = np.hypot(legs[:, 0], legs[:, 1]) > 1e-6
    if not defined.any():
        return np.zeros(len(waypoints))
    source = np.maximum.accumulate(np.where(defined, np.arange(len(legs)), -1))
    source[source < 0] = int(np.argmax(defined))
    heading = np.arctan2(legs[:, 1], legs[:, 0])[source]
    return np.unwrap(np.append(heading, heading[-1]))


def _within_limits(states: FlatStates, limits: FlightLimits) -> bool:
    speed = np.linalg.norm(states.velocity, axis=1)
    rates = np.linalg.norm(states.body_rates, axis=1)
    return bool(
        speed.max() <= limits.max_speed
        and states.thrust.max() <= limits.max_thrust
        and states.thrust.min() >= limits.min_thrust
        and rates.max() <= limits.max_body_rate
    )


def trajectory_through(waypoints: np.ndarray, boxes: np.ndarray, limits: FlightLimits) -> Flight:
    """The minimum-snap flight through ``waypoints`` (K, 3) with the trajectory clearance and
    within the limits; FlightError when midpoints run out."""
    points = np.asarray(waypoints, float)
    splits = 0
    while True:
        times = ramp_times(points, limits.max_speed, limits.max_acceleration)
        path = minimum_snap(points, times)
        time = np.arange(0.0, path.duration, SAMPLE_DT)
        positions = path.evaluate(np.append(time, path.duration))
        close = box_distance(positions, boxes) < limits.trajectory_clearance
        if not close.any():
            break
        if splits == MAX_SPLITS:
            raise FlightError(
                f"the trajectory stays closer than {limits.trajectory_clearance} m to a solid after {MAX_SPLITS} midpoints"
            )
        splits += 1
        piece = (
            np.searchsorted(path.starts, np.append(time, path.duration)[close], side="right") - 1
        )
        worst = int(np.bincount(np.clip(piece, 0, len(times) - 1)).argmax())
        middle = (points[worst] + points[worst + 1]) / 2
        points = np.insert(points, worst + 1, middle, axis=0)
    yaw = minimum_snap(_headings(points)[:, None], times)
    for slow_down in range(MAX_SLOW_DOWN):
        factor = SLOW_DOWN**slow_down
        flight = Flight(points, path.scaled(factor), yaw.scaled(factor), factor, splits)
        time = np.append(np.arange(0.0, flight.duration, SAMPLE_DT), flight.duration)
        if _within_limits(flight.states(time), limits):
            return flight
    raise FlightError("no time scaling brings the trajectory within the limits")


def plan_flight(
    volume: Volume, start: np.ndarray, goal: np.ndarray, limits: FlightLimits
) -> Flight:
    """An expert flight from ``start`` to ``goal`` (world metres, each the centre of a free
    voxel of the inflated grid)."""
    r = volume.resolution
    free = free_space(volume.occupancy, r, limits.clearance)
    to_index = lambda p: tuple(int(v) for v in np.floor(np.asarray(p)[::-1] / r))  # noqa: E731
    chain = voxel_path(free, to_index(start), to_index(goal))
    if not chain:
        raise FlightError(
            f"no path of clearance {limits.clearance} m from {np.round(start, 2).tolist()} to {np.round(goal, 2).tolist()}"
        )
    boxes = volume.boxes()
    points = np.array(
        [
            np.asarray(start, float),
            *[voxel_centre(c, r) for c in chain[1:-1]],
            np.asarray(goal, float),
        ]
    )
    return trajectory_through(pulled_taut(points, boxes, limits.clearance), boxes, limits)
