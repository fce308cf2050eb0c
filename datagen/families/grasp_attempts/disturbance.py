"""Objects moving faster than the hand could push them: the trace of a physics-engine glitch (a
contact generated deep inside a thin part throws a light object out of the tray), which would
otherwise be labelled as an ordinary miss.

After every physics step each object's speed over the last ``WINDOW`` seconds (its centre of
mass's displacement over the window, divided by it) is compared with what the robot could have
given it. A rigid body moving at u gives a resting object at most (1 + e) u, restitution e <= 1,
so the limit is ``PUSH_FACTOR`` times the fastest point of any robot link during the window (per
link: its centre's speed plus its angular speed times the farthest point of its collision shapes
from the centre) plus ``SPEED_FLOOR``, what toppling and a bounce after a drop give without the
hand. A downward displacement is left out: falling is gravity's work; the window leaves out an
object chattering in place between the fingers, which goes nowhere. The window where an object
most exceeds its limit is kept; an attempt where any object exceeded it is ``disturbed``. Reads
only: watching leaves the physics alone.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import sapien

PUSH_FACTOR = 2.0
SPEED_FLOOR = 0.5  # m/s
WINDOW = 0.05  # s


def pushed_speed(velocity: np.ndarray) -> np.ndarray:
    """(...,) the length of ``velocity`` (..., 3) without a downward (-z) component."""
    velocity = np.asarray(velocity, float)
    up = np.maximum(velocity[..., 2], 0.0)
    return np.sqrt(velocity[..., 0] ** 2 + velocity[..., 1] ** 2 + up**2)


def _shape_points(shape: sapien.physx.PhysxCollisionShape) -> np.ndarray:
    """(N, 3) points in the shape's frame that bound it (corners, vertices, axis ends)."""
    if isinstance(shape, sapien.physx.PhysxCollisionShapeBox):
        corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
        return corners * np.asarray(shape.half_size, float)
    if isinstance(
        shape,
        sapien.physx.PhysxCollisionShapeConvexMesh | sapien.physx.PhysxCollisionShapeTriangleMesh,
    ):
        return np.asarray(shape.get_vertices(), float) * np.asarray(shape.get_scale(), float)
    if isinstance(shape, sapien.physx.PhysxCollisionShapeSphere):
        return np.eye(3) * shape.radius
    # capsule, cylinder: along x, radius around it
    reach = shape.half_length + shape.radius
    return np.eye(3) * np.array([reach, shape.radius, shape.radius])


def link_radius(link: sapien.physx.PhysxArticulationLinkComponent) -> float:
    """Metres from the link's centre of mass to the farthest point of its collision shapes."""
    com = link.cmass_local_pose.to_transformation_matrix()
    centre = com[:3, 3]
    radius = 0.0
    for shape in link.get_collision_shapes():
        local = shape.get_local_pose().to_transformation_matrix()
        points = _shape_points(shape) @ local[:3, :3].T + local[:3, 3]
        radius = max(radius, float(np.linalg.norm(points - centre, axis=1).max(initial=0.0)))
    return radius


@dataclass
class Peak:
    """The window where an object came nearest to (or farthest past) its limit."""

    excess: float = -np.inf  # m/s: speed - limit
    speed: float = 0.0  # m/s over the window, downward displacement left out
    hand_speed: float = 0.0  # m/s, the robot's fastest point during the window
    instance_id: int = 0
    step: int = 0  # the window's last
    phase: str = ""

    @property
    def limit(self) -> float:
        return PUSH_FACTOR * self.hand_speed + SPEED_FLOOR


def _length(vector: np.ndarray) -> np.float32:
    """``np.linalg.norm`` of a float32 3-vector, the same float32 (the square root taken in
    float64 and rounded) at half its cost: called twice for every link every step."""
    return np.float32(math.sqrt(vector.dot(vector)))


def _centres(bodies: Sequence[sapien.physx.PhysxRigidDynamicComponent]) -> np.ndarray:
    """(N, 3) world centres of mass."""
    return np.array([(b.entity_pose * b.cmass_local_pose).p for b in bodies], float).reshape(-1, 3)


class DisturbanceWatch:
    """Kept by the executor: ``observe`` after every physics step."""

    def __init__(
        self,
        robot: sapien.physx.PhysxArticulation,
        objects: Sequence[tuple[int, sapien.physx.PhysxRigidDynamicComponent]],
        timestep: float,
    ):
        self.links = list(robot.get_links())
        self.radii = np.array([link_radius(link) for link in self.links])
        self.ids = [instance_id for instance_id, _ in objects]
        self.bodies = [body for _, body in objects]
        self.timestep, self.steps = timestep, max(1, round(WINDOW / timestep))
        self.centres = collections.deque([_centres(self.bodies)], maxlen=self.steps + 1)
        self.hands = collections.deque([self.hand_speed()], maxlen=self.steps)
        self.peak = Peak()

    def hand_speed(self) -> float:
        """m/s: the fastest point of any robot link now (a bound, from centres and spins)."""
        linear = np.array([_length(link.linear_velocity) for link in self.links])
        angular = np.array([_length(link.angular_velocity) for link in self.links])
        return float((linear + angular * self.radii).max(initial=0.0))

    def observe(self, step: int, phase: str) -> None:
        """Compares each object's speed over the window that step ``step`` ends with the hand's
        during it."""
        self.centres.append(_centres(self.bodies))
        if len(self.centres) > self.steps and self.ids:
            hand = max(self.hands)
            limit = PUSH_FACTOR * hand + SPEED_FLOOR
            speeds = pushed_speed(self.centres[-1] - self.centres[0]) / (self.steps * self.timestep)
            worst = int(np.argmax(speeds))
            if speeds[worst] - limit > self.peak.excess:
                speed = float(speeds[worst])
                self.peak = Peak(speed - limit, speed, hand, self.ids[worst], step, phase)
        self.hands.append(self.hand_speed())

    @property
    def disturbed(self) -> bool:
        return self.peak.excess > 0.0

    def to_json(self) -> dict[str, object]:
        """The peak: object speed, hand speed and limit (m/s, over ``window`` s ending at
        ``time``, ``step``), which object."""
        peak = self.peak
        return {
            "disturbed": self.disturbed,
            "object_speed": round(peak.speed, 4),
            "hand_speed": round(peak.hand_speed, 4),
            "limit": round(peak.limit, 4),
            "instance_id": peak.instance_id,
            "time": round(peak.step * self.timestep, 6),
            "step": peak.step,
            "window": round(self.steps * self.timestep, 6),
            "phase": peak.phase,
        }
