"""Minimum-snap trajectories: pieces of degree 7 through waypoints, at rest at both ends.

With degree-7 pieces (8 coefficients a piece and axis), the positions at the waypoints, the
velocity, acceleration and jerk zero at both ends and the derivatives 1..6 continuous where two
pieces meet make a square linear system, whose solution is the trajectory of least integrated
squared snap through those waypoints at those times (the Euler-Lagrange conditions of the
problem; rotorpy's ``trajectories/minsnap.py`` solves the same). Each piece is written in its own
normalised time s = t / T_i in [0, 1], which keeps the system well conditioned and makes a
uniform time scaling free: scaling every T_i by k leaves the coefficients as they are.

Segment times start from a trapezoidal velocity ramp over each leg's length
(:func:`ramp_times`, as ethz-asl/mav_trajectory_generation's ``computeTimeVelocityRamp``) and are
then scaled up by the caller until the vehicle's limits hold.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np

DEGREE = 7
COEFFICIENTS = DEGREE + 1
END_DERIVATIVES = 3  # velocity, acceleration, jerk zero at both ends
CONTINUOUS = 6  # derivatives continuous where two pieces meet


def _basis(s: float | np.ndarray, derivative: int) -> np.ndarray:
    """d^derivative/ds^derivative of [1, s, ..., s^7] at ``s``: (..., 8)."""
    s = np.asarray(s, float)
    out = np.zeros((*s.shape, COEFFICIENTS))
    for k in range(derivative, COEFFICIENTS):
        out[..., k] = factorial(k) // factorial(k - derivative) * s ** (k - derivative)
    return out


@dataclass(frozen=True)
class PiecewisePolynomial:
    """Pieces of degree 7 in normalised time: piece i is ``sum_k coefficients[i, k] s^k`` with
    s = (t - start_i) / times[i]. ``coefficients`` (M, 8, D), ``times`` (M,) seconds."""

    times: np.ndarray
    coefficients: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.times.sum())

    @property
    def starts(self) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(self.times)[:-1]])

    def scaled(self, factor: float) -> PiecewisePolynomial:
        """The same path flown ``factor`` times slower (velocities / factor, accelerations /
        factor², ...): only the times change."""
        return PiecewisePolynomial(self.times * factor, self.coefficients)

    def evaluate(self, t: np.ndarray | float, derivative: int = 0) -> np.ndarray:
        """(len(t), D): the ``derivative``-th time derivative at times ``t`` (seconds, clipped
        to [0, duration])."""
        t = np.clip(np.atleast_1d(np.asarray(t, float)), 0.0, self.duration)
        piece = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.times) - 1)
        span = self.times[piece]
        s = (t - self.starts[piece]) / span
        basis = _basis(s, derivative)  # (n, 8)
        values = np.einsum("nk,nkd->nd", basis, self.coefficients[piece])
        return values / span[:, None] ** derivative


def minimum_snap(waypoints: np.ndarray, times: np.ndarray) -> PiecewisePolynomial:
    """The minimum-snap trajectory through ``waypoints`` (N+1, D) with piece durations ``times``
    (N,) seconds, at rest (velocity, acceleration, jerk zero) at both ends."""
    waypoints = np.asarray(waypoints, float)
    times = np.asarray(times, float)
    pieces = len(times)
    if waypoints.ndim != 2 or len(waypoints) != pieces + 1 or pieces < 1:
        raise ValueError(
            f"expected N+1 waypoints for N >= 1 times, got {waypoints.shape} and {times.shape}"
        )
    if np.any(times <= 0):
        raise ValueError(f"piece times must be positive, got {times.tolist()}")
    size = COEFFICIENTS * pieces
    a = np.zeros((size, size))
    b = np.zeros((size, waypoints.shape[1]))
    row = 0

    def put(piece: int, s: float, derivative: int, scale: float = 1.0) -> None:
        a[row, COEFFICIENTS * piece : COEFFICIENTS * (piece + 1)] += scale * _basis(s, derivative)

    for i in range(pieces):
        put(i, 0.0, 0)
        b[row] = waypoints[i]
        row += 1
        put(i, 1.0, 0)
        b[row] = waypoints[i + 1]
        row += 1
    for derivative in range(1, END_DERIVATIVES + 1):
        put(0, 0.0, derivative)
        row += 1
        put(pieces - 1, 1.0, derivative)
        row += 1
    for i in range(pieces - 1):
        ratio = times[i] / times[i + 1]  # both sides in piece i's time units: well scaled
        for derivative in range(1, CONTINUOUS + 1):
            put(i, 1.0, derivative)
            put(i + 1, 0.0, derivative, -(ratio**derivative))
            row += 1
    assert row == size
    coefficients = np.linalg.solve(a, b).reshape(pieces, COEFFICIENTS, -1)
    return PiecewisePolynomial(times.copy(), coefficients)


def ramp_times(waypoints: np.ndarray, max_speed: float, max_acceleration: float) -> np.ndarray:
    """(N,) seconds per leg: a trapezoidal velocity ramp over its straight length, from rest to
    rest: ``2 sqrt(d / a)`` when ``d < v² / a``, else ``2 v / a + (d - v² / a) / v``."""
    d = np.linalg.norm(np.diff(np.asarray(waypoints, float), axis=0), axis=1)
    v, a = max_speed, max_acceleration
    short = d < v * v / a
    return np.where(short, 2 * np.sqrt(d / a), 2 * v / a + (d - v * v / a) / v)
