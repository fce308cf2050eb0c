"""Differential flatness (datagen/families/aerial/flatness.py): the thrust points along the acceleration
plus gravity, the body rates are the rotation's own derivative, the IMU integrates back to the
trajectory, and an independent implementation gives the same thrust and thrust direction."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from datagen.families.aerial.flatness import GRAVITY, flat_states, quaternion_xyzw
from datagen.families.aerial.minsnap import minimum_snap, ramp_times

WAYPOINTS = np.array([[0.0, 0.0, 1.0], [2.0, 0.0, 1.5], [2.0, 3.0, 1.0], [0.0, 3.5, 2.0]])


def _flight(slow: float = 1.3):
    path = minimum_snap(WAYPOINTS, ramp_times(WAYPOINTS, 2.0, 3.0)).scaled(slow)
    yaw = minimum_snap(np.array([[0.0], [0.0], [np.pi / 2], [np.pi]]), path.times)
    return path, yaw


def test_thrust_is_acceleration_plus_gravity_along_body_z():
    path, yaw = _flight()
    s = flat_states(path, yaw, np.linspace(0, path.duration, 500))
    lift = s.acceleration + np.array([0.0, 0.0, GRAVITY])
    assert np.allclose(s.rotation[:, :, 2] * s.thrust[:, None], lift, atol=1e-9)
    assert np.allclose(s.specific_force, np.c_[np.zeros((500, 2)), s.thrust], atol=1e-9)
    assert np.allclose(np.einsum("nij,nik->njk", s.rotation, s.rotation), np.eye(3), atol=1e-9)
    # the yaw fixes the heading: body y is level-perpendicular to (cos yaw, sin yaw, 0), so body x
    # lies in the vertical plane of that heading (Mellinger and Kumar's construction)
    heading = np.stack([np.cos(s.yaw), np.sin(s.yaw), np.zeros_like(s.yaw)], axis=1)
    assert np.abs(np.sum(s.rotation[:, :, 1] * heading, axis=1)).max() < 1e-9
    assert (np.sum(s.rotation[:, :, 0] * heading, axis=1) > 0).all()


def test_body_rates_are_the_rotations_derivative():
    path, yaw = _flight()
    t = np.linspace(0.1, path.duration - 0.1, 200)
    h = 1e-5
    s, before, after = (flat_states(path, yaw, t + d) for d in (0.0, -h, h))
    rate = np.einsum("nji,njk->nik", s.rotation, (after.rotation - before.rotation) / (2 * h))
    numeric = np.stack([rate[:, 2, 1], rate[:, 0, 2], rate[:, 1, 0]], axis=1)
    assert np.abs(numeric - s.body_rates).max() < 1e-6


def test_the_imu_integrates_back_to_the_trajectory():
    """Attitude from the gyroscope (exact rotation per step), velocity and position from the
    accelerometer rotated into the world, gravity removed; started from the first state."""
    path, yaw = _flight()
    dt = 1e-3
    t = np.arange(0.0, path.duration, dt)
    s = flat_states(path, yaw, t)
    rotation, velocity, position = s.rotation[0], s.velocity[0].copy(), s.position[0].copy()
    for k in range(len(t) - 1):
        world = rotation @ s.specific_force[k] - [0.0, 0.0, GRAVITY]
        mid = rotation @ Rotation.from_rotvec(s.body_rates[k] * dt / 2).as_matrix()
        world_mid = mid @ ((s.specific_force[k] + s.specific_force[k + 1]) / 2) - [
            0.0,
            0.0,
            GRAVITY,
        ]
        position += velocity * dt + 0.5 * world * dt * dt + (world_mid - world) * dt * dt / 3
        velocity += world_mid * dt
        rotation = (
            rotation
            @ Rotation.from_rotvec((s.body_rates[k] + s.body_rates[k + 1]) / 2 * dt).as_matrix()
        )
    assert np.linalg.norm(position - s.position[-1]) < 0.01  # metres after the whole flight
    assert np.linalg.norm(velocity - s.velocity[-1]) < 0.01
    assert np.abs(rotation - s.rotation[-1]).max() < 0.01


def test_an_independent_implementation_gives_the_same_thrust():
    import minsnap_trajectories as oracle  # a dev dependency (pyproject.toml)

    path, yaw = _flight()
    times = np.append(path.starts, path.duration)
    zero = np.zeros(3)
    references = [
        oracle.Waypoint(time=float(t), position=p, **({"velocity": zero, "acceleration": zero, "jerk": zero} if i in (0, len(times) - 1) else {}))
        for i, (t, p) in enumerate(zip(times, WAYPOINTS, strict=True))
    ]  # fmt: skip
    polys = oracle.generate_trajectory(
        references, degree=7, idx_minimized_orders=4, num_continuous_orders=4
    )
    sample = np.linspace(0.0, path.duration, 200)
    theirs = oracle.compute_quadrotor_trajectory(polys, sample, vehicle_mass=1.0, yaw="velocity")
    ours = flat_states(path, yaw, sample)
    assert np.allclose(theirs.thrust, ours.thrust, rtol=1e-4, atol=1e-4)
    # their yaw convention differs: compare the thrust direction (body z) only
    their_z = Rotation.from_quat(theirs.attitude[:, [1, 2, 3, 0]]).as_matrix()[:, :, 2]
    their_z_alt = Rotation.from_quat(theirs.attitude).as_matrix()[:, :, 2]
    ours_z = ours.rotation[:, :, 2]
    assert min(np.abs(their_z - ours_z).max(), np.abs(their_z_alt - ours_z).max()) < 1e-4


def test_quaternions_are_unit_with_non_negative_w():
    path, yaw = _flight()
    q = quaternion_xyzw(flat_states(path, yaw, np.linspace(0, path.duration, 50)).rotation)
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0) and (q[:, 3] >= 0).all()
