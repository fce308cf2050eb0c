"""Each drone's IMU at a sensor rate (``aerial.imu_hz``), with the trajectory it was sampled from.

Per drone k, part ``imu.d<k>.npz``: at episode times ``time_s`` = i / rate (i = 0, 1, ... up to
the episode's end), the ideal readings of an IMU at the centre of mass (body frame, x forward,
y left, z up): ``accelerometer`` the specific force R^T (a + g e_z) in m/s², ``gyroscope`` the
body rates in rad/s (:mod:`datagen.families.aerial.flatness`, exact); the ground truth beside them
(``position``, ``velocity`` world metres and m/s, ``quaternion_xyzw`` body to world), and what
every value was sampled from: ``take_off_s``, ``piece_times_s`` (M,), ``position_coefficients``
(M, 8, 3) and ``yaw_coefficients`` (M, 8) of :class:`datagen.families.aerial.minsnap.PiecewisePolynomial`.

With ``aerial.imu_noise.enabled``, ``accelerometer_noisy`` / ``gyroscope_noisy`` and the biases
they carry (``accelerometer_bias`` / ``gyroscope_bias``) too: per axis, Kalibr's model
(continuous-time densities sigma_n, sigma_b; dt = 1 / rate): ``noisy_i = ideal_i + b_i +
sigma_n / sqrt(dt) * w_i``, ``b_0 = 0``, ``b_(i+1) = b_i + sigma_b * sqrt(dt) * v_i``, w and v
standard normal from ``sample_rng(seed, index, "aerial_imu.d<k>")``.
"""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np

from datagen.config.aerial import ImuNoiseConfig
from datagen.families.aerial.flatness import quaternion_xyzw
from datagen.families.aerial.fleet import Agent

IMU_PART = "imu.d{k}.npz"
IMU_STREAM = "aerial_imu.d{k}"
# (reading, noise density key, random walk key) of the noise model, in draw order
SENSORS = (
    ("accelerometer", "accelerometer_noise_density", "accelerometer_random_walk"),
    ("gyroscope", "gyroscope_noise_density", "gyroscope_random_walk"),
)


def imu_times(duration: float, rate_hz: float) -> np.ndarray:
    """(n,) seconds i / rate for every i with i / rate <= ``duration``."""
    return np.arange(math.floor(duration * rate_hz + 1e-9) + 1) / rate_hz


def noisy(
    rng: np.random.Generator, ideal: np.ndarray, density: float, random_walk: float, rate: float
) -> tuple[np.ndarray, np.ndarray]:
    """(noisy readings, the bias in each) of ``ideal`` (n, 3): white noise of ``density`` and a
    bias random walk of ``random_walk`` (continuous-time, per sqrt(Hz)) at ``rate`` Hz."""
    white = rng.standard_normal(ideal.shape) * (density * math.sqrt(rate))
    steps = rng.standard_normal(ideal.shape) * (random_walk / math.sqrt(rate))
    bias = np.concatenate([np.zeros((1, ideal.shape[1])), np.cumsum(steps[:-1], axis=0)])
    return ideal + bias + white, bias


def imu_arrays(
    agent: Agent, rate_hz: float, duration: float, noise: ImuNoiseConfig, rng: np.random.Generator
) -> dict[str, np.ndarray]:
    """Every array of one drone's ``imu.d<k>.npz`` (module docstring) over an episode of
    ``duration`` seconds; ``rng`` draws the noise when ``noise.enabled``."""
    times = imu_times(duration, rate_hz)
    states = agent.states(times)
    arrays: dict[str, np.ndarray] = {
        "time_s": times,
        "accelerometer": states.specific_force,
        "gyroscope": states.body_rates,
        "position": states.position,
        "velocity": states.velocity,
        "quaternion_xyzw": quaternion_xyzw(states.rotation),
        "take_off_s": np.asarray(agent.take_off, np.float64),
        "piece_times_s": agent.flight.path.times,
        "position_coefficients": agent.flight.path.coefficients,
        "yaw_coefficients": agent.flight.yaw.coefficients[..., 0],
    }
    if noise.enabled:
        for reading, density, walk in SENSORS:
            arrays[f"{reading}_noisy"], arrays[f"{reading}_bias"] = noisy(
                rng, arrays[reading], getattr(noise, density), getattr(noise, walk), rate_hz
            )
    return arrays


def npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def imu_metadata(rate_hz: float, noise: ImuNoiseConfig) -> dict[str, Any]:
    """What the episode's JSON says of the IMU streams."""
    return {
        "part": IMU_PART.replace("{k}", "<k>"),
        "rate_hz": float(rate_hz),
        "frame": "body: x forward, y left, z up, at the centre of mass; world z up, g = 9.81",
        "noise": {
            "model": "kalibr: white noise and bias random walk per axis, biases start at 0",
            "stream": IMU_STREAM.replace("{k}", "<k>"),
            **{key: getattr(noise, key) for _, *keys in SENSORS for key in keys},
        }
        if noise.enabled
        else None,
    }
