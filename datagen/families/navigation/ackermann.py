"""Pure-pursuit path following for a car-like robot with Ackermann steering (the kinematic bicycle
model at the body's centre, Kong et al. 2015), simulated at a fixed control rate, forward only.

State (x, y, yaw) at the body's centre, which is the centre of the footprint disk the planner
inflates for and the collision checks test, ``rear`` metres ahead of the rear axle's centre;
command (v m/s, the body centre's speed; δ rad, the steering angle of the virtual middle front
wheel). Over one step both are constant: the car turns about a fixed point on the rear axle's
line, so its rear axle drives an arc of curvature ``tan(δ) / wheelbase`` and its centre an arc of
curvature ``cos(β) tan(δ) / wheelbase`` heading ``yaw + β``, the slip angle
``β = atan(rear tan(δ) / wheelbase)`` (integrated in closed form). With ``|δ| <= max_steer`` the
rear axle never turns tighter than ``wheelbase / tan(max_steer)``
(``CarParams.min_turning_radius``). Pure pursuit picks the turn whose centre passes through the
look-ahead point and clamps the steering it needs. A car cannot turn on the spot: the episode
starts heading along the path's first leg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from datagen.families.navigation.follow import Trajectory, arc, pursue, wrap_angle
from datagen.floorplans.grid import Layout


@dataclass(frozen=True)
class CarParams:
    wheelbase: float  # metres between the axles
    max_steer: float  # radians
    rear: float = 0.0  # metres from the rear axle's centre forward to the body's centre (the pose)
    lookahead: float = 0.6  # metres along the path ahead of the closest point
    max_linear: float = 0.6  # m/s
    rate_hz: float = 10.0  # control rate
    goal_tolerance: float = 0.2  # metres
    robot_radius: float = 0.3  # footprint disk for the collision flag, metres

    @property
    def min_turning_radius(self) -> float:
        """Metres: the tightest arc the car drives (its rear axle's centre)."""
        return self.wheelbase / math.tan(self.max_steer)

    @property
    def min_centre_turning_radius(self) -> float:
        """Metres: the tightest arc its body's centre (the pose) drives."""
        return math.hypot(self.min_turning_radius, self.rear)


def bicycle_step(
    x: float, y: float, yaw: float, v: float, steer: float, wheelbase: float, rear: float, dt: float
) -> tuple[float, float, float]:
    """The body centre's pose after holding (v, steer) for ``dt`` seconds (see the module)."""
    slip = math.atan(rear * math.tan(steer) / wheelbase)
    curvature = math.cos(slip) * math.tan(steer) / wheelbase
    x, y, turned = arc(x, y, yaw + slip, curvature, v * dt)
    return x, y, wrap_angle(yaw + turned)


def pursuit_steer(
    x: float, y: float, yaw: float, target, wheelbase: float, rear: float, max_steer: float
) -> float:
    """The steering angle (radians, within ``max_steer``) of the turn that takes the body's centre
    through ``target``: its centre of rotation lies on the rear axle's line, as far from the body's
    centre as from the target."""
    ax, ay = x - rear * math.cos(yaw), y - rear * math.sin(yaw)  # the rear axle's centre
    dx, dy = target[0] - ax, target[1] - ay
    lateral = -math.sin(yaw) * dx + math.cos(yaw) * dy  # the target's offset to the left
    spread = dx * dx + dy * dy - rear * rear
    if spread <= 1e-9:  # the target is no farther than the body's centre: turn fully its way
        return math.copysign(max_steer, lateral) if lateral else 0.0
    steer = math.atan(wheelbase * 2.0 * lateral / spread)  # curvature of the rear axle's arc
    return max(-max_steer, min(max_steer, steer))


def follow_ackermann(path_world, params: CarParams, layout: Layout | None = None) -> Trajectory:
    """Drive the body's centre from the path's first point, heading along its first leg, to its
    last; commands are (v, steering angle). Collisions are checked against ``layout.grid`` when a
    layout is given."""
    p = params

    def bicycle(x, y, yaw, target, distance, dt):
        steer = pursuit_steer(x, y, yaw, target, p.wheelbase, p.rear, p.max_steer)
        v = min(p.max_linear, max(0.1, distance))  # slow down near the goal
        return (v, steer), bicycle_step(x, y, yaw, v, steer, p.wheelbase, p.rear, dt)

    return pursue(
        path_world,
        None,
        p.lookahead,
        p.max_linear,
        p.rate_hz,
        p.goal_tolerance,
        p.robot_radius,
        bicycle,
        layout,
    )
