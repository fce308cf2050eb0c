"""Minimum-snap trajectories (datagen/families/aerial/minsnap.py): through every waypoint, at rest at both
ends, smooth where pieces meet, the least snap (an independent implementation agrees), and a
time scaling changes only the speed."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.families.aerial.minsnap import minimum_snap, ramp_times

WAYPOINTS = np.array(
    [[0.0, 0.0, 1.0], [2.0, 0.0, 1.5], [2.0, 3.0, 1.0], [0.0, 3.5, 2.0], [-1.0, 1.0, 1.2]]
)


def _trajectory():
    return minimum_snap(WAYPOINTS, ramp_times(WAYPOINTS, 2.0, 3.0))


def test_passes_every_waypoint_and_rests_at_both_ends():
    path = _trajectory()
    at = np.append(path.starts, path.duration)
    assert np.allclose(path.evaluate(at), WAYPOINTS, atol=1e-9)
    for derivative in (1, 2, 3):
        assert np.allclose(path.evaluate([0.0, path.duration], derivative), 0.0, atol=1e-9)


@pytest.mark.parametrize("derivative", range(7))
def test_derivatives_up_to_the_sixth_are_continuous_where_pieces_meet(derivative):
    path = _trajectory()
    scale = np.abs(path.evaluate(np.linspace(0, path.duration, 400), derivative)).max()
    for t in path.starts[1:]:
        before, after = path.evaluate([t - 1e-9], derivative), path.evaluate([t + 1e-9], derivative)
        assert np.allclose(before, after, atol=1e-5 * max(scale, 1.0)), (derivative, t)


def test_the_least_snap_of_an_independent_solver():
    import minsnap_trajectories as oracle  # a dev dependency (pyproject.toml)

    path = _trajectory()
    times = np.append(path.starts, path.duration)
    zero = np.zeros(3)
    references = [
        oracle.Waypoint(time=float(t), position=p, **({"velocity": zero, "acceleration": zero, "jerk": zero} if i in (0, len(times) - 1) else {}))
        for i, (t, p) in enumerate(zip(times, WAYPOINTS, strict=True))
    ]  # fmt: skip
    polys = oracle.generate_trajectory(
        references, degree=7, idx_minimized_orders=4, num_continuous_orders=4
    )
    sample = np.linspace(0.0, path.duration, 301)
    theirs = oracle.compute_trajectory_derivatives(polys, sample, 3)  # (orders, n, 3)
    for derivative in range(3):
        assert np.allclose(path.evaluate(sample, derivative), theirs[derivative], atol=1e-6)


def test_scaling_the_times_flies_the_same_path_slower():
    path = _trajectory()
    slow = path.scaled(2.0)
    assert slow.duration == pytest.approx(2 * path.duration)
    u = np.linspace(0, 1, 50)
    assert np.allclose(slow.evaluate(u * slow.duration), path.evaluate(u * path.duration))
    assert np.allclose(slow.evaluate(u * slow.duration, 1), path.evaluate(u * path.duration, 1) / 2)
    assert np.allclose(slow.evaluate(u * slow.duration, 2), path.evaluate(u * path.duration, 2) / 4)


def test_ramp_times_follow_the_trapezoid():
    times = ramp_times(
        np.array([[0.0, 0, 0], [0.5, 0, 0], [10.5, 0, 0]]), max_speed=2.0, max_acceleration=1.0
    )
    # 0.5 m < v²/a = 4 m: 2 sqrt(d / a); 10 m: 2 v / a + (d - v² / a) / v
    assert times == pytest.approx([2 * np.sqrt(0.5), 4.0 + 3.0])


def test_bad_input_is_refused_clearly():
    with pytest.raises(ValueError, match="N\\+1 waypoints"):
        minimum_snap(WAYPOINTS, np.ones(2))
    with pytest.raises(ValueError, match="positive"):
        minimum_snap(WAYPOINTS[:2], np.array([0.0]))
