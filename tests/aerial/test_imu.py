"""The IMU stream (datagen/families/aerial/imu.py) as a user reads it from ``imu.d<k>.npz``: integrated
alone from its state at t = 0 (an independent 4th-order Runge-Kutta strapdown,
tests/aerial/aerial_strapdown.py) it stays within 1 cm and 0.1 degrees of the ground truth over
every whole flight and ends at the goal; the stored polynomials, evaluated by numpy alone, give
its positions and velocities; the seeded noise has the white-noise and bias random-walk
statistics its densities say, and the same seed gives the same bytes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from aerial_strapdown import strapdown_errors

from datagen.config import config_from_dict
from datagen.config.aerial import EUROC_IMU, ImuNoiseConfig
from datagen.dataset.episode_parts import imu_stream
from datagen.errors import ConfigError
from datagen.families.aerial.episode import plan_aerial_episode
from datagen.families.aerial.imu import imu_arrays, imu_times, noisy, npz_bytes
from datagen.seeding import sample_rng

RATE = 200.0  # Hz, the default
QUIET = ImuNoiseConfig()  # noise off
EPISODES = [
    ("corridor", 2, 0),
    ("rooms", 1, 1),
    ("maze", 1, 2),
    ("corridor", 3, 3),
    ("rooms", 2, 4),
    ("maze", 2, 5),
]


def _cfg(family: str, drones: int, **aerial):
    return config_from_dict(
        {"scene": "aerial", "aerial": {"family": family, "drones": drones, **aerial}}
    ).aerial


def _stored(agent, duration: float, noise: ImuNoiseConfig = QUIET, seed: int = 0):
    """The arrays of the drone's part, through its bytes and the loader's decoding."""
    rng = sample_rng(seed, 0, "aerial_imu.d0")
    data = npz_bytes(imu_arrays(agent, RATE, duration, noise, rng))
    return imu_stream(data, "imu.d0.npz"), data


@pytest.fixture(scope="module", params=EPISODES, ids=lambda p: f"{p[0]}-{p[1]}-{p[2]}")
def episode(request):
    family, drones, index = request.param
    return plan_aerial_episode(_cfg(family, drones), 11, index)


def test_the_stream_integrates_back_to_every_whole_flight(episode):
    for agent in episode.agents:
        imu, _ = _stored(agent, episode.duration)
        assert imu["time_s"][0] == 0.0 and imu["time_s"][-1] >= agent.landing  # the whole flight
        position_m, attitude_deg, end = strapdown_errors(imu)
        assert position_m < 0.01 and attitude_deg < 0.1, (position_m, attitude_deg)
        assert np.linalg.norm(end - agent.goal) < 0.01
        np.testing.assert_allclose(imu["position"][0], agent.start, atol=1e-9)


def test_the_polynomials_give_the_stream(episode):
    """As docs/aerial.md says to resample: piece i of the flight (time t - take_off) is
    sum_k c[i, k] s^k with s = (t - take_off - start_i) / T_i."""
    agent = episode.agents[-1]
    imu, _ = _stored(agent, episode.duration)
    times, coefficients = imu["piece_times_s"], imu["position_coefficients"]
    starts = np.concatenate([[0.0], np.cumsum(times)])
    flight = np.clip(imu["time_s"] - imu["take_off_s"], 0.0, starts[-1])
    piece = np.clip(np.searchsorted(starts, flight, side="right") - 1, 0, len(times) - 1)
    s = (flight - starts[piece]) / times[piece]
    for n, key in enumerate(("position", "velocity")):
        values = (
            np.stack(
                [
                    [
                        np.polynomial.polynomial.polyval(
                            x, np.polynomial.polynomial.polyder(coefficients[i, :, a], n)
                        )
                        for a in range(3)
                    ]
                    for x, i in zip(s, piece, strict=True)
                ]
            )
            / times[piece, None] ** n
        )
        np.testing.assert_allclose(values, imu[key], atol=1e-9)
    yaw = [
        np.polynomial.polynomial.polyval(x, imu["yaw_coefficients"][i])
        for x, i in zip(s, piece, strict=True)
    ]
    # the yaw fixes the heading as Mellinger and Kumar's construction does: body y is level-
    # perpendicular to (cos yaw, sin yaw, 0)
    level = np.stack([np.cos(yaw), np.sin(yaw), np.zeros(len(yaw))], axis=1)
    assert np.abs(np.sum(_body_axis(imu["quaternion_xyzw"], 1) * level, axis=1)).max() < 1e-9


def _body_axis(q: np.ndarray, axis: int) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(q).as_matrix()[:, :, axis]


def test_sample_times():
    times = imu_times(7.3125, RATE)
    assert times[0] == 0.0 and np.allclose(np.diff(times), 1 / RATE)
    assert times[-1] <= 7.3125 < times[-1] + 1 / RATE
    assert imu_times(2.0, RATE)[-1] == 2.0  # an end on a sample is kept


def test_the_noise_has_its_densities_statistics(episode):
    """Per axis: white noise of std density * sqrt(rate) at the sample rate, bias increments of
    std random_walk / sqrt(rate), readings = ideal + bias + white noise."""
    noise = ImuNoiseConfig(enabled=True)
    imu, _ = _stored(episode.agents[0], episode.duration, noise)
    for sensor in ("accelerometer", "gyroscope"):
        density, walk = EUROC_IMU[f"{sensor}_noise_density"], EUROC_IMU[f"{sensor}_random_walk"]
        white = imu[f"{sensor}_noisy"] - imu[sensor] - imu[f"{sensor}_bias"]
        assert np.std(white) == pytest.approx(density * math.sqrt(RATE), rel=0.1)
        assert abs(np.mean(white)) < 4 * density * math.sqrt(RATE / white.size)
        steps = np.diff(imu[f"{sensor}_bias"], axis=0)
        assert np.std(steps) == pytest.approx(walk / math.sqrt(RATE), rel=0.1)
        assert np.all(imu[f"{sensor}_bias"][0] == 0.0)


def _allan_deviation(x: np.ndarray, rate: float, tau: float) -> float:
    """Overlapping Allan deviation of readings ``x`` (n,) at averaging time ``tau`` seconds."""
    m = round(tau * rate)
    theta = np.concatenate([[0.0], np.cumsum(x)]) / rate  # integrated readings
    d = theta[2 * m :] - 2 * theta[m:-m] + theta[: -2 * m]
    return float(np.sqrt(np.mean(d**2) / (2 * tau * tau)))


def test_allan_deviation_follows_white_noise_then_the_random_walk():
    """Two hours of an accelerometer at rest: sigma(tau)^2 = N^2 / tau + K^2 tau / 3 (N the
    noise density, K the random walk; IEEE 952's slopes -1/2 and +1/2)."""
    n_density, k_walk = (
        EUROC_IMU["accelerometer_noise_density"],
        EUROC_IMU["accelerometer_random_walk"],
    )
    readings, _ = noisy(
        np.random.default_rng(3), np.zeros((int(2 * 3600 * RATE), 1)), n_density, k_walk, RATE
    )
    for tau, tolerance in ((0.05, 0.05), (1.0, 0.1), (30.0, 0.25), (200.0, 0.4)):
        expected = math.sqrt(n_density**2 / tau + k_walk**2 * tau / 3)
        assert _allan_deviation(readings[:, 0], RATE, tau) == pytest.approx(expected, rel=tolerance)


def test_the_same_seed_gives_the_same_bytes_and_each_drone_its_own_noise():
    episode = plan_aerial_episode(_cfg("corridor", 2), 11, 0)
    noise = ImuNoiseConfig(enabled=True)
    _, a = _stored(episode.agents[0], episode.duration, noise, seed=4)
    _, b = _stored(episode.agents[0], episode.duration, noise, seed=4)
    _, c = _stored(episode.agents[0], episode.duration, noise, seed=5)
    assert a == b and a != c
    first = sample_rng(4, 0, "aerial_imu.d0").standard_normal(3)
    second = sample_rng(4, 0, "aerial_imu.d1").standard_normal(3)
    assert not np.allclose(first, second)
    quiet, _ = _stored(episode.agents[0], episode.duration)
    assert "accelerometer_noisy" not in quiet and "gyroscope_bias" not in quiet


@pytest.mark.parametrize(
    ("aerial", "message"),
    [
        ({"imu_hz": 5}, r"aerial\.imu_hz: expected values in \[10\.0, 2000\.0\]"),
        (
            {"imu_noise": {"gyroscope_random_walk": -1.0}},
            r"aerial\.imu_noise\.gyroscope_random_walk: expected",
        ),
        ({"imu_noise": {"enabled": 1}}, r"aerial\.imu_noise\.enabled: expected true or false"),
        ({"stereo_baseline": 0.8}, r"aerial\.stereo_baseline: expected values in \[0\.0, 0\.5\]"),
    ],
)
def test_bad_values_are_refused_naming_the_key(aerial, message):
    with pytest.raises(ConfigError, match=message) as error:
        _cfg("corridor", 1, **aerial)
    assert "\n" not in str(error.value)
