"""Expert flights (datagen/families/aerial/planning.py, fleet.py, episode.py): collision-free at their
clearance, smooth, within the limits, never shorter than the episode's lower bound (to the goal's
centre: a straight flight has an SPL of 1), and the drones of one episode never closer than two
radii and a margin."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.config import config_from_dict
from datagen.families.aerial.airframe import bounding_radius, camera_reach
from datagen.families.aerial.episode import flown_length, path_lower_bound, plan_aerial_episode
from datagen.families.aerial.fleet import Agent, closest_approach, separation
from datagen.families.aerial.planning import FlightLimits, plan_flight
from datagen.families.aerial.volumes import Solid, Volume, box_distance
from datagen.floorplans.grid import Layout
from datagen.outcomes import spl
from datagen.registries import AIRFRAMES

DT = 0.005  # seconds: finer than the planner's own checks


def _config(family: str, drones: int):
    return config_from_dict(
        {"scene": "aerial", "aerial": {"family": family, "drones": drones}}
    ).aerial


@pytest.fixture(scope="module", params=[("corridor", 1, 0), ("maze", 1, 1), ("rooms", 2, 2), ("corridor", 3, 3)],
                ids=lambda p: f"{p[0]}-{p[1]}-drones-{p[2]}")  # fmt: skip
def episode(request):
    family, drones, index = request.param
    cfg = _config(family, drones)
    return cfg, plan_aerial_episode(cfg, 7, index)


def test_every_flight_keeps_its_clearance_from_every_solid(episode):
    _, ep = episode
    boxes = ep.volume.boxes()
    for agent, limits in zip(ep.agents, ep.limits, strict=True):
        t = np.append(np.arange(0.0, agent.flight.duration, DT), agent.flight.duration)
        gaps = box_distance(agent.flight.path.evaluate(t), boxes)
        assert gaps.min() >= limits.trajectory_clearance - 1e-6
        assert np.allclose(
            agent.flight.path.evaluate([0.0, agent.flight.duration]), [agent.start, agent.goal]
        )


def test_flights_are_smooth_and_within_their_limits(episode):
    cfg, ep = episode
    for agent in ep.agents:
        flight = agent.flight
        t = np.append(np.arange(0.0, flight.duration, DT), flight.duration)
        s = flight.states(t)
        assert np.linalg.norm(s.velocity, axis=1).max() <= cfg.max_speed + 1e-6
        assert cfg.min_thrust - 1e-6 <= s.thrust.min() and s.thrust.max() <= cfg.max_thrust + 1e-6
        assert np.linalg.norm(s.body_rates, axis=1).max() <= cfg.max_body_rate + 1e-6
        # continuous: no jump between samples larger than the next derivative allows
        for value, rate in (
            (s.position, s.velocity),
            (s.velocity, s.acceleration),
            (s.acceleration, s.jerk),
        ):
            bound = np.abs(rate).max() * DT * 1.01 + 1e-9
            assert np.abs(np.diff(value, axis=0)).max() <= bound
        assert np.allclose(s.velocity[[0, -1]], 0.0, atol=1e-9)


def test_no_flight_is_shorter_than_the_lower_bound(episode):
    _, ep = episode
    for agent, limits in zip(ep.agents, ep.limits, strict=True):
        bound = path_lower_bound(ep.volume, agent, limits)
        straight = np.linalg.norm(agent.goal - agent.start)
        assert straight - 1e-6 <= bound <= flown_length(agent)


def test_a_straight_expert_flight_scores_an_spl_of_one():
    """Habitat's SPL: success * l / max(p, l), l the shortest path to the goal the expert flies
    to (its centre); a straight flight through an empty room is that path."""
    layout = Layout(np.zeros((60, 80), bool), 0.05, "rooms", walls=[])
    volume = Volume(layout, 3.0, 0.1, [Solid("ceiling", (0.0, 0.0, 3.0, 4.0, 3.0, 3.1))])
    limits = FlightLimits(radius=0.25)
    start, goal = np.array([0.55, 0.65, 0.85]), np.array([3.35, 2.25, 2.05])
    agent = Agent(start, goal, plan_flight(volume, start, goal, limits), 0.0)
    assert len(agent.flight.waypoints) == 2  # straight
    shortest = path_lower_bound(volume, agent, limits)
    assert shortest == pytest.approx(np.linalg.norm(goal - start), abs=1e-9)
    assert spl(True, shortest, flown_length(agent)) == 1.0


def test_drones_never_come_closer_than_two_radii_and_a_margin(episode):
    _, ep = episode
    for i, a in enumerate(ep.agents):
        for j in range(i):
            apart = separation(ep.limits[i], ep.limits[j])
            assert closest_approach(a, ep.agents[j], ep.duration) >= apart - 1e-9
            assert np.linalg.norm(a.goal - ep.agents[j].goal) >= apart


def test_the_same_episode_is_drawn_from_the_same_seed_and_index():
    cfg = _config("maze", 2)
    a, b = plan_aerial_episode(cfg, 3, 4), plan_aerial_episode(cfg, 3, 4)
    assert all(np.array_equal(x.flight.waypoints, y.flight.waypoints) and x.take_off == y.take_off
               for x, y in zip(a.agents, b.agents, strict=True))  # fmt: skip


def test_a_stereo_pairs_right_camera_is_inside_the_planned_radius():
    cfg = config_from_dict(
        {"scene": "aerial", "aerial": {"stereo_baseline": 0.4, "drones": 2}}
    ).aerial
    ep = plan_aerial_episode(cfg, 7, 0)
    for shape, limits in zip(ep.shapes, ep.limits, strict=True):
        quadrotor = AIRFRAMES["quadrotor"]
        assert (
            limits.radius >= camera_reach(quadrotor, shape, 0.4) > bounding_radius(quadrotor, shape)
        )
