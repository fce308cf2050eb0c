"""Pure-pursuit path following for a car-like robot with Ackermann steering (the kinematic bicycle
model), simulated at a fixed control rate, forward only.

State (x, y, yaw) at the rear axle's centre; command (v m/s, δ rad, the steering angle of the
virtual middle front wheel). Over one step both are constant, so the car drives an arc of
curvature ``tan(δ) / wheelbase`` exactly (integrated in closed form): with ``|δ| <= max_steer``
it never turns tighter than ``wheelbase / tan(max_steer)`` (``CarParams.min_turning_radius``).
Pure pursuit picks the curvature of the arc through the look-ahead point, ``2 sin(α) / d``, and
clamps the steering it needs. A car cannot turn on the spot: the episode starts heading along the
path's first leg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from datagen.navigation.follow import Trajectory, _wrap, pursue
from datagen.navigation.grid import Layout


@dataclass(frozen=True)
class CarParams:
    wheelbase: float  # metres between the axles
    max_steer: float  # radians
    lookahead: float = 0.6  # metres along the path ahead of the closest point
    max_linear: float = 0.6  # m/s
    rate_hz: float = 10.0  # control rate
    goal_tolerance: float = 0.2  # metres
    robot_radius: float = 0.3  # footprint disk for the collision flag, metres

    @property
    def min_turning_radius(self) -> float:
        """Metres: the tightest arc the car drives (its rear axle's centre)."""
        return self.wheelbase / math.tan(self.max_steer)


def _arc(x: float, y: float, yaw: float, v: float, steer: float, wheelbase: float, dt: float):
    """The pose after driving ``v * dt`` metres along the arc of the steering angle."""
    curvature = math.tan(steer) / wheelbase
    distance = v * dt
    if abs(curvature) < 1e-9:
        return x + distance * math.cos(yaw), y + distance * math.sin(yaw), yaw
    turned = yaw + curvature * distance
    return (
        x + (math.sin(turned) - math.sin(yaw)) / curvature,
        y - (math.cos(turned) - math.cos(yaw)) / curvature,
        _wrap(turned),
    )


def follow_ackermann(path_world, params: CarParams, layout: Layout | None = None) -> Trajectory:
    """Drive from the path's first point, heading along its first leg, to its last; commands are
    (v, steering angle). Collisions are checked against ``layout.grid`` when a layout is given."""
    p = params

    def bicycle(x, y, yaw, target, distance, dt):
        reach = max(math.hypot(target[0] - x, target[1] - y), 1e-6)
        alpha = _wrap(math.atan2(target[1] - y, target[0] - x) - yaw)
        steer = math.atan(p.wheelbase * 2.0 * math.sin(alpha) / reach)
        steer = max(-p.max_steer, min(p.max_steer, steer))
        v = min(p.max_linear, max(0.1, distance))  # slow down near the goal
        return (v, steer), _arc(x, y, yaw, v, steer, p.wheelbase, dt)

    return pursue(
        path_world, None, p.lookahead, p.max_linear, p.rate_hz, p.goal_tolerance,
        p.robot_radius, bicycle, layout,
    )  # fmt: skip
