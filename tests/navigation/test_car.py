"""The seed's maze experiment: a car-like robot with Ackermann steering in a four-arm maze
(datagen/navigation/ackermann.py, layouts.plus_maze, worlds/car.py): it never turns tighter than
its minimum turning radius, drives from one arm's end to another's without touching a wall, never
shorter than SPL's lower bound, and its camera rides on it."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from datagen.config import load_config
from datagen.navigation.ackermann import CarParams, _arc, follow_ackermann
from datagen.navigation.episode import car_params, plan_episode
from datagen.navigation.layouts import make_layout
from datagen.scenes.navigation_episodes import planar_pose, produce
from datagen.worlds.floorplan import NAV_CLASS_ID

CONFIG = "configs/nav_plus_maze_car.yaml"


def _turn_rates(poses: np.ndarray) -> np.ndarray:
    """Per step, the curvature (1/m) of the arc from one pose to the next: an arc turning by t
    over a chord c has curvature 2 sin(t / 2) / c."""
    chord = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    turned = np.abs((np.diff(poses[:, 2]) + np.pi) % (2 * np.pi) - np.pi)
    return 2 * np.sin(turned[chord > 1e-9] / 2) / chord[chord > 1e-9]


def test_a_step_drives_an_exact_arc_of_the_steering_angle():
    wheelbase, steer = 0.3, math.radians(25)
    radius = wheelbase / math.tan(steer)
    x, y, yaw = 0.0, 0.0, 0.0
    for _ in range(100):  # a whole circle in 100 steps: back where it began
        x, y, yaw = _arc(x, y, yaw, 2 * math.pi * radius, steer, wheelbase, 0.01)
    assert (x, y) == pytest.approx((0.0, 0.0), abs=1e-9) and abs(yaw) < 1e-9
    x, y, _ = _arc(0.0, 0.0, 0.0, math.pi * radius / 2, steer, wheelbase, 1.0)  # a quarter turn
    assert (x, y) == pytest.approx((radius, radius))


def test_the_four_arm_maze_has_four_equal_arms_and_free_ends():
    layout = make_layout("plus_maze", np.random.default_rng(0))
    ends, junction = np.array(layout.params["arm_ends"]), np.array(layout.params["junction"])
    reach = np.linalg.norm(ends - junction, axis=1)
    assert np.allclose(reach, reach[0])
    for x, y in [*ends, junction]:
        assert not layout.grid[int(y / layout.resolution), int(x / layout.resolution)]


def test_the_car_never_turns_tighter_than_its_radius_and_reaches_every_goal():
    cfg = load_config(CONFIG).navigation
    params = car_params(cfg)
    layout_ends = None
    for index in range(20):
        episode = plan_episode(cfg, 0, index)
        traj = episode.trajectory
        assert traj.success and not traj.collision.any(), index
        assert _turn_rates(traj.poses).max() <= 1 / params.min_turning_radius + 1e-9
        assert np.abs(traj.commands[:, 1]).max() <= math.radians(cfg.max_steering_deg) + 1e-12
        assert (traj.commands[:, 0] > 0).all()  # forward only
        assert episode.travelled_m >= episode.shortest_path_m
        layout_ends = np.array(episode.layout.params["arm_ends"])
        start_end = np.argmin(np.linalg.norm(layout_ends - episode.path[0], axis=1))
        goal_end = np.argmin(np.linalg.norm(layout_ends - episode.path[-1], axis=1))
        assert start_end != goal_end  # from one arm's end to another's


def test_a_tight_corner_is_taken_wide_not_tighter():
    params = CarParams(wheelbase=0.3, max_steer=math.radians(20), lookahead=0.2)
    path = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])  # a right angle: tighter than it can turn
    traj = follow_ackermann(path, params)
    assert _turn_rates(traj.poses).max() <= 1 / params.min_turning_radius + 1e-9


@pytest.mark.sim
def test_the_camera_rides_on_the_car_and_the_car_is_labelled():
    config = load_config(CONFIG)
    config = config.replace(render=config.render.__class__(width=96, height=72, far=20.0))
    sample = produce(config, 0, 2)
    meta = json.loads(sample.parts["json"])
    assert meta["robot"]["name"] == "car" and meta["robot"]["commands"] == [
        "linear_m_s",
        "steering_rad",
    ]
    assert [t["class"] for t in meta["things"]].count("car") == 1
    mount = np.asarray(meta["camera"]["camera_in_robot"])
    for frame in meta["frames"]:
        E = np.asarray(frame["extrinsics_world_to_camera"])
        np.testing.assert_allclose(np.linalg.inv(E), planar_pose(*frame["pose"]) @ mount, atol=2e-4)
        assert all(t["class"] != "car" for t in frame["things"])  # itself is not a thing it sees
    assert meta["episode"]["success"] and meta["episode"]["spl"] <= 1.0
    assert "car" in meta["classes"] and meta["classes"].index("car") == NAV_CLASS_ID["car"]
