"""A strapdown integrator for the stored IMU streams, written apart from datagen's flatness code
(tests/aerial/test_imu.py, test_aerial_scene.py): classic 4th-order Runge-Kutta over two sample
intervals at a time (the middle sample is the step's midpoint), state (q, v, p) with the attitude
a unit Hamilton quaternion (x, y, z, w, body to world); ``q' = q (x) (omega, 0) / 2``,
``v' = R(q) f - g e_z``, ``p' = v``; g = 9.81 m/s²."""

from __future__ import annotations

import numpy as np

G = np.array([0.0, 0.0, -9.81])  # m/s², world z up


def _product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    (ax, ay, az, aw), (bx, by, bz, bw) = a, b
    return np.array(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    )


def matrix(q: np.ndarray) -> np.ndarray:
    """3x3 rotation of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _rates(q: np.ndarray, v: np.ndarray, force: np.ndarray, omega: np.ndarray):
    return 0.5 * _product(q, np.append(omega, 0.0)), matrix(q) @ force + G, v


def integrate(time, accelerometer, gyroscope, position, velocity, quaternion):
    """(indices, positions, velocities, quaternions): the states integrated from the initial one
    (position, velocity (3,), quaternion (4,) at ``time[0]``) at samples 0, 2, 4, ... of the
    readings (n, 3), with a step of two sample intervals."""
    q, v, p = (
        np.asarray(quaternion, float),
        np.asarray(velocity, float),
        np.asarray(position, float),
    )
    out = [(0, p.copy(), v.copy(), q.copy())]
    for k in range(0, len(time) - 2, 2):
        h = time[k + 2] - time[k]
        f, w = accelerometer[k : k + 3], gyroscope[k : k + 3]
        k1 = _rates(q, v, f[0], w[0])
        k2 = _rates(q + h / 2 * k1[0], v + h / 2 * k1[1], f[1], w[1])
        k3 = _rates(q + h / 2 * k2[0], v + h / 2 * k2[1], f[1], w[1])
        k4 = _rates(q + h * k3[0], v + h * k3[1], f[2], w[2])
        step = [h / 6 * (a + 2 * b + 2 * c + d) for a, b, c, d in zip(k1, k2, k3, k4, strict=True)]
        q, v, p = q + step[0], v + step[1], p + step[2]
        q /= np.linalg.norm(q)
        out.append((k + 2, p.copy(), v.copy(), q.copy()))
    indices, positions, velocities, quaternions = zip(*out, strict=True)
    return np.array(indices), np.array(positions), np.array(velocities), np.array(quaternions)


def angle_between(q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(n,) radians between quaternions (n, 4), normalised first (stored ones are rounded)."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    r = r / np.linalg.norm(r, axis=-1, keepdims=True)
    dot = np.clip(np.abs(np.sum(q * r, axis=-1)), 0.0, 1.0)
    return 2 * np.arccos(dot)


def strapdown_errors(imu: dict[str, np.ndarray]) -> tuple[float, float, np.ndarray]:
    """(worst position error in metres, worst attitude error in degrees, the last integrated
    position) of the stream ``imu`` (the arrays of an ``imu.d<k>.npz``) integrated from its
    state at t = 0, against the ground truth stored beside it."""
    indices, positions, _, quaternions = integrate(
        imu["time_s"],
        imu["accelerometer"],
        imu["gyroscope"],
        imu["position"][0],
        imu["velocity"][0],
        imu["quaternion_xyzw"][0],
    )
    position_error = np.linalg.norm(positions - imu["position"][indices], axis=1).max()
    angle = angle_between(quaternions, imu["quaternion_xyzw"][indices]).max()
    return float(position_error), float(np.degrees(angle)), positions[-1]
