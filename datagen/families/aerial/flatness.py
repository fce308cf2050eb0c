"""A quadrotor's attitude, collective thrust, body rates and IMU readings from its flat outputs
(position and yaw over time), by differential flatness (Mellinger and Kumar, ICRA 2011).

World z up, g = 9.81 m/s². Mass-normalised collective thrust c (m/s²) along the body z axis:
``t = a + g e_z``, ``c = |t|``, ``z_B = t / c``; from the yaw ψ, ``x_C = (cos ψ, sin ψ, 0)``,
``y_B = (z_B × x_C) / |z_B × x_C|``, ``x_B = y_B × z_B``, ``R = [x_B y_B z_B]`` (body to world).
Body rates ω (body frame, rad/s) are exact, from the derivatives of those axes:
``ω_x = ẏ_B · z_B``, ``ω_y = ż_B · x_B``, ``ω_z = ẋ_B · y_B`` (so ``ω_x = -(y_B · j) / c`` and
``ω_y = (x_B · j) / c``, with j the jerk). An ideal IMU at the centre of mass reads the specific
force ``R^T (a + g e_z) = (0, 0, c)`` and the angular rate ω. Singular where c = 0 (free fall):
trajectories are kept above a least thrust.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from datagen.families.aerial.minsnap import PiecewisePolynomial

GRAVITY = 9.81  # m/s²
E_Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class FlatStates:
    """Everything at ``time`` (n,): world position, velocity, acceleration, jerk (n, 3); yaw and
    its rate (n,); body-to-world rotation (n, 3, 3); thrust c (n,) m/s²; body rates (n, 3) rad/s;
    specific force in the body frame (n, 3) m/s²."""

    time: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    yaw: np.ndarray
    yaw_rate: np.ndarray
    rotation: np.ndarray
    thrust: np.ndarray
    body_rates: np.ndarray
    specific_force: np.ndarray


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / norm, norm


def _unit_rate(u: np.ndarray, norm: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """d/dt (v / |v|) given u = v / |v|, |v| and dv/dt."""
    return (rate - np.sum(u * rate, axis=-1, keepdims=True) * u) / norm


def flat_states(
    path: PiecewisePolynomial, yaw: PiecewisePolynomial, time: np.ndarray
) -> FlatStates:
    """The states at ``time`` of a quadrotor flying ``path`` (3 axes) with heading ``yaw`` (1 axis,
    radians, same piece times)."""
    time = np.asarray(time, float)
    p, v, a, j = (path.evaluate(time, d) for d in range(4))
    psi, psi_rate = yaw.evaluate(time, 0)[:, 0], yaw.evaluate(time, 1)[:, 0]
    z_b, thrust = _unit(a + GRAVITY * E_Z)
    z_rate = _unit_rate(z_b, thrust, j)
    x_c = np.stack([np.cos(psi), np.sin(psi), np.zeros_like(psi)], axis=-1)
    x_c_rate = psi_rate[:, None] * np.stack([-np.sin(psi), np.cos(psi), np.zeros_like(psi)], -1)
    u = np.cross(z_b, x_c)
    y_b, u_norm = _unit(u)
    y_rate = _unit_rate(y_b, u_norm, np.cross(z_rate, x_c) + np.cross(z_b, x_c_rate))
    x_b = np.cross(y_b, z_b)
    x_rate = np.cross(y_rate, z_b) + np.cross(y_b, z_rate)
    rates = np.stack(
        [np.sum(y_rate * z_b, -1), np.sum(z_rate * x_b, -1), np.sum(x_rate * y_b, -1)], axis=-1
    )
    rotation = np.stack([x_b, y_b, z_b], axis=-1)
    force = np.einsum("nji,nj->ni", rotation, a + GRAVITY * E_Z)
    return FlatStates(time, p, v, a, j, psi, psi_rate, rotation, thrust[:, 0], rates, force)


def quaternion_xyzw(rotation: np.ndarray) -> np.ndarray:
    """(n, 4) unit quaternions (x, y, z, w), w >= 0, of rotation matrices (n, 3, 3)."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(rotation).as_quat()
    return np.where(q[:, 3:] < 0, -q, q)
