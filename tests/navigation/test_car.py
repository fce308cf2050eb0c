"""The seed's maze experiment: a car-like robot with Ackermann steering in a four-arm maze
(datagen/families/navigation/ackermann.py, layouts.plus_maze, worlds/car.py): it never turns tighter than
its minimum turning radius, drives from one arm's end to another's without its body touching a
wall (its pose is its body's centre, the centre of the footprint disk), never shorter than SPL's
lower bound, and its camera rides on it. Its own view: tests/navigation/test_car_view.py."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from datagen.config import config_from_dict, load_config
from datagen.config.sections import RenderConfig
from datagen.families.navigation.ackermann import CarParams, bicycle_step, follow_ackermann
from datagen.families.navigation.episode import car_params, plan_episode
from datagen.families.navigation.fleet import plan_fleet_episode
from datagen.families.navigation.one_robot import planar_pose, produce
from datagen.families.navigation.world import NAV_CLASS_ID
from datagen.floorplans.layouts import make_layout

CONFIG = "configs/nav_plus_maze_car.yaml"
# docs/navigation.md, in footprint radii: the body 1.6 x 1.0 about the pose, the axles 0.5 behind
# and 0.54 ahead of it, wheels 0.36 across and 0.12 wide at 0.44 either side of the middle
BODY, REAR, FRONT, TRACK, WHEEL = (1.6, 1.0), -0.5, 0.54, 0.44, math.hypot(0.18, 0.06)


def _turn_rates(poses: np.ndarray) -> np.ndarray:
    """Per step, the curvature (1/m) of the arc from one pose to the next: an arc turning by t
    over a chord c has curvature 2 sin(t / 2) / c."""
    chord = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    turned = np.abs((np.diff(poses[:, 2]) + np.pi) % (2 * np.pi) - np.pi)
    return 2 * np.sin(turned[chord > 1e-9] / 2) / chord[chord > 1e-9]


def _separated(polygon: np.ndarray, rect) -> bool:
    """True unless the convex ``polygon`` (n, 2) and the axis-aligned ``rect`` (x0, y0, x1, y1)
    overlap by more than 0.1 mm (separating axes: the rectangle's and the polygon's edges')."""
    x0, y0, x1, y1 = rect
    box = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    edges = np.diff(np.vstack([polygon, polygon[:1]]), axis=0)
    axes = [np.array([1.0, 0.0]), np.array([0.0, 1.0]), *(np.array([-e[1], e[0]]) for e in edges)]
    for axis in axes:
        a, b = polygon @ axis / np.linalg.norm(axis), box @ axis / np.linalg.norm(axis)
        if a.max() <= b.min() + 1e-4 or b.max() <= a.min() + 1e-4:
            return True
    return False


def _distance(point: np.ndarray, rect) -> float:
    x0, y0, x1, y1 = rect
    return math.hypot(
        max(x0 - point[0], 0.0, point[0] - x1), max(y0 - point[1], 0.0, point[1] - y1)
    )


def car_outline(x: float, y: float, yaw: float, radius: float):
    """The body's corners (4, 2) and the wheels' centres (4, 2), world metres."""
    rotation = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    half = np.array(BODY) * radius / 2
    body = np.array([(1, 1), (1, -1), (-1, -1), (-1, 1)]) * half
    wheels = np.array([(a, side * TRACK) for a in (REAR, FRONT) for side in (1, -1)]) * radius
    return body @ rotation.T + (x, y), wheels @ rotation.T + (x, y)


def assert_car_clear(poses: np.ndarray, layout, radius: float, what: str) -> None:
    """At every pose, the car's body rectangle and its wheels (a disk about each, whatever the
    steering) touch no wall or obstacle rectangle of the layout (as rendered)."""
    rects = [*layout.walls, *layout.obstacles]
    for k, pose in enumerate(poses):
        body, wheels = car_outline(*pose, radius)
        for rect in rects:
            assert _separated(body, rect), f"{what}, step {k}: the body overlaps {rect}"
            for wheel in wheels:
                gap = _distance(wheel, rect) - WHEEL * radius
                assert gap >= 0, f"{what}, step {k}: a wheel on {rect}"


def test_a_step_drives_an_exact_arc_of_the_steering_angle():
    """About the centre of rotation on the rear axle's line, the body's centre circles at the
    radius hypot(wheelbase / tan(steer), rear)."""
    wheelbase, rear, steer = 0.3, 0.12, math.radians(25)
    radius = wheelbase / math.tan(steer)  # the rear axle's
    around = math.hypot(radius, rear)  # the body centre's
    x, y, yaw = 0.0, 0.0, 0.0
    for _ in range(100):  # a whole circle in 100 steps: back where it began
        x, y, yaw = bicycle_step(x, y, yaw, 2 * math.pi * around, steer, wheelbase, rear, 0.01)
    assert (x, y) == pytest.approx((0.0, 0.0), abs=1e-9) and abs(yaw) < 1e-9
    # a quarter turn about (-rear, radius): the centre from (0, 0) to (radius - rear, radius + rear)
    x, y, yaw = bicycle_step(0.0, 0.0, 0.0, math.pi * around / 2, steer, wheelbase, rear, 1.0)
    assert (x, y, yaw) == pytest.approx((radius - rear, radius + rear, math.pi / 2))


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
    for index in range(20):
        episode = plan_episode(cfg, 0, index)
        traj = episode.trajectory
        assert traj.success and not traj.collision.any(), index
        assert _turn_rates(traj.poses).max() <= 1 / params.min_centre_turning_radius + 1e-9
        assert np.abs(traj.commands[:, 1]).max() <= math.radians(cfg.max_steering_deg) + 1e-12
        assert (traj.commands[:, 0] > 0).all()  # forward only
        assert episode.travelled_m >= episode.shortest_path_m
        layout_ends = np.array(episode.layout.params["arm_ends"])
        start_end = np.argmin(np.linalg.norm(layout_ends - episode.path[0], axis=1))
        goal_end = np.argmin(np.linalg.norm(layout_ends - episode.path[-1], axis=1))
        assert start_end != goal_end  # from one arm's end to another's


def test_no_car_body_ever_touches_a_wall():
    """Every control step of 30 episodes of one car and 6 of two: the rectangle and wheels
    checked against the layout's rectangles, independently of the grid and its disk."""
    cfg = load_config(CONFIG).navigation
    for index in range(30):
        episode = plan_episode(cfg, 1, index)
        poses, layout = episode.trajectory.poses, episode.layout
        assert_car_clear(poses, layout, cfg.robot_radius, f"episode {index}")
    two = config_from_dict(
        {"scene": "navigation", "navigation": {**_car(), "robots": 2}}
    ).navigation
    for index in range(6):
        fleet = plan_fleet_episode(two, 1, index)
        for k, agent in enumerate(fleet.agents):
            poses = agent.episode.trajectory.poses
            assert_car_clear(poses, fleet.layout, two.robot_radius, f"fleet {index}, car {k}")


def _car() -> dict:
    return {"family": "plus_maze", "robot": "car", "robot_radius": 0.25, "lookahead": 0.7}


def test_a_tight_corner_is_taken_wide_not_tighter():
    params = CarParams(wheelbase=0.3, max_steer=math.radians(20), rear=0.1, lookahead=0.2)
    path = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])  # a right angle: tighter than it can turn
    traj = follow_ackermann(path, params)
    assert _turn_rates(traj.poses).max() <= 1 / params.min_centre_turning_radius + 1e-9


@pytest.mark.sim
def test_the_camera_rides_on_the_car_and_the_car_is_labelled():
    config = load_config(CONFIG)
    config = config.replace(render=RenderConfig(width=96, height=72, far=20.0))
    sample = produce(config, 0, 2)
    meta = json.loads(sample.parts["json"])
    assert meta["robot"]["name"] == "car" and meta["robot"]["commands"] == [
        "linear_m_s",
        "steering_rad",
    ]
    assert meta["robot"]["rear_axle_behind_m"] == pytest.approx(0.125)
    assert [t["class"] for t in meta["things"]].count("car") == 1
    mount = np.asarray(meta["camera"]["camera_in_robot"])
    walls = meta["episode"]["layout"]["walls"]
    for frame in meta["frames"]:
        E = np.asarray(frame["extrinsics_world_to_camera"])
        np.testing.assert_allclose(np.linalg.inv(E), planar_pose(*frame["pose"]) @ mount, atol=2e-4)
        assert all(t["class"] != "car" for t in frame["things"])  # itself is not a thing it sees
        # the gap is the footprint disk's, about the pose (the body's centre)
        gap = min(_distance(np.array(frame["pose"][:2]), w) for w in walls) - 0.25
        assert frame["obstacle_gap"] == pytest.approx(gap, abs=1e-5)
    assert meta["episode"]["success"] and meta["episode"]["spl"] <= 1.0
    assert "car" in meta["classes"] and meta["classes"].index("car") == NAV_CLASS_ID["car"]
