"""The robot randomiser's look (``robot.pose: look``, issue 39 item 5): where the wrist camera
is drawn, within the config's ranges, leaning towards the base, straight down for an arm whose
approach stays in the base's vertical plane; ``ready`` draws the same joints and no look."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from datagen.config import config_from_dict
from datagen.config.robot import robot_spec, robot_workspace
from datagen.errors import ConfigError
from datagen.randomisers.robot import draw_robot
from datagen.seeding import sample_rng


def _robot(name: str, pose: str = "look"):
    return config_from_dict({"version": 1, "robot": {"name": name, "pose": pose}}).robot


@pytest.mark.parametrize("name", ["panda", "iiwa14", "so100"])
def test_the_look_lies_within_the_configured_ranges(name):
    cfg = _robot(name)
    ws = robot_workspace(cfg)
    floor = np.asarray(ws.tray_floor_top, float)
    base = np.asarray(ws.robot_base, float)
    for index in range(100):
        look = draw_robot(sample_rng(0, index, "robot"), cfg, ws).look
        eye, target, up = (np.asarray(v, float) for v in (look.eye, look.target, look.up))
        assert target[2] == pytest.approx(floor[2])
        assert (np.abs(target[:2] - floor[:2]) <= cfg.look.offset * ws.scale + 1e-6).all()
        height = eye[2] - floor[2]
        low, high = np.multiply(cfg.look.height, robot_spec(cfg).look_scale)
        assert low - 1e-6 <= height <= high + 1e-6
        tilt = np.degrees(np.arctan2(np.linalg.norm(eye[:2] - target[:2]), height))
        if name == "so100":  # approach in the base's vertical plane: straight down
            assert tilt < 1e-3
        else:
            assert tilt <= cfg.look.tilt_deg[1] + 1e-3
            assert (eye - target)[:2] @ (base - target)[:2] >= -1e-9  # leans to the base's side
        assert up[2] == 0 and np.linalg.norm(up) == pytest.approx(1, abs=1e-5)
        roll = np.degrees(np.arctan2(up[1], up[0]))
        assert cfg.look.roll_deg[0] - 1e-3 <= roll <= cfg.look.roll_deg[1] + 1e-3


def test_ready_draws_the_same_joints_and_no_look():
    look, ready = _robot("panda"), _robot("panda", "ready")
    ws = robot_workspace(look)
    with_look = draw_robot(sample_rng(3, 5, "robot"), look, ws)
    without = draw_robot(sample_rng(3, 5, "robot"), ready, ws)
    assert with_look.look is not None and without.look is None
    assert with_look.qpos == without.qpos


def test_an_unknown_pose_is_refused_naming_the_key():
    with pytest.raises(ConfigError, match=r"robot\.pose: expected one of \['look', 'ready'\]"):
        config_from_dict({"version": 1, "robot": {"pose": "sideways"}})


def test_a_narrower_range_is_kept():
    cfg = _robot("panda")
    cfg = replace(cfg, look=replace(cfg.look, height=(0.5, 0.5), tilt_deg=(0.0, 0.0)))
    ws = robot_workspace(cfg)
    look = draw_robot(sample_rng(0, 0, "robot"), cfg, ws).look
    assert look.eye[2] - ws.tray_floor_top[2] == pytest.approx(0.5)
    assert look.eye[:2] == pytest.approx(look.target[:2])


def test_the_look_aims_towards_where_the_objects_were_dropped_within_the_tray():
    cfg = _robot("panda")
    ws = robot_workspace(cfg)
    centre, half = np.asarray(ws.tray_floor_top[:2]), np.asarray(ws.tray_inner_half)
    for aim, expected in (
        (np.add(centre, [0.05, -0.04]), np.add(centre, [0.05, -0.04])),  # near: the aim itself
        (np.add(centre, [1.0, 1.0]), centre + half / 2),  # far off: half the inner half away
    ):
        look = draw_robot(sample_rng(0, 1, "robot"), cfg, ws, np.asarray(aim)).look
        off = np.asarray(look.target[:2]) - expected
        assert (np.abs(off) <= cfg.look.offset + 1e-6).all()
