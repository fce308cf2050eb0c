"""Settling a freshly built scene: physics steps until the dropped objects are at rest, at most
``physics.settle_time`` of simulated time.

Every ``CHECK_EVERY`` steps each object's speed is read: the larger of its centre's linear speed
and the surface speed of its rotation (angular speed times half its largest extent), metres per
second. Settling stops once every object has stayed below ``physics.settle_velocity`` at
``REST_CHECKS`` checks in a row. The decision depends only on the simulated state, so a sample
remains a function of (seed, index). ``settle_velocity: 0`` always runs the full settle time.

The robot is put to sleep first: its PD drives already hold the sampled joint positions, and a
sleeping articulation costs no solver time (about half of a step in the default grasp scene)
and does not sag under gravity. PhysX wakes it if an object touches it; it is woken again
before the caller moves it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import sapien

CHECK_EVERY = 10  # steps between speed checks
REST_CHECKS = 2  # consecutive checks every object must pass


def surface_speeds(bodies: Sequence[sapien.physx.PhysxRigidDynamicComponent], radii) -> np.ndarray:
    """(N,) metres per second: max(|v|, |omega| * radius) per body."""
    linear = np.array([np.linalg.norm(b.linear_velocity) for b in bodies], float)
    angular = np.array([np.linalg.norm(b.angular_velocity) for b in bodies], float)
    return np.maximum(linear, angular * np.asarray(radii, float))


def at_rest(speed_history: Sequence[float], settle_velocity: float) -> bool:
    """True when the last ``REST_CHECKS`` maxima of the objects' speeds are below the limit."""
    recent = speed_history[-REST_CHECKS:]
    return len(recent) == REST_CHECKS and max(recent) < settle_velocity


def settle(
    scene: sapien.Scene,
    bodies: Sequence[sapien.physx.PhysxRigidDynamicComponent],
    radii: Sequence[float],
    robot: sapien.physx.PhysxArticulation | None,
    max_steps: int,
    settle_velocity: float,
) -> int:
    """Steps ``scene`` until ``bodies`` rest or ``max_steps`` is reached; returns the steps."""
    if robot is not None:
        robot.get_links()[0].put_to_sleep()
    history: list[float] = []
    steps = 0
    while steps < max_steps:
        scene.step()
        steps += 1
        if settle_velocity > 0 and steps % CHECK_EVERY == 0:
            history.append(float(surface_speeds(bodies, radii).max(initial=0.0)))
            if at_rest(history, settle_velocity):
                break
    if robot is not None:
        robot.get_links()[0].wake_up()
    return steps
