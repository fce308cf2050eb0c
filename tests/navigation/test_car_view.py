"""A robot's camera never sees the robot itself (docs/navigation.md; issue 39, item 7): the car's
camera looks out from the front of its mast's pod, ahead of every part of the car, so a view
within 90 degrees of straight ahead misses it; Fetch's head camera misses its base up to 75
degrees down. Rendered: every frame of many episodes, and single frames at the extremes of the
ranges the config accepts, at several aspect ratios (and just beyond them, where the robot is
seen, so the check can fail)."""

from __future__ import annotations

import dataclasses
import json

import cv2
import numpy as np
import pytest

from datagen.config import config_from_dict, load_config
from datagen.config.sections import RenderConfig
from datagen.errors import ConfigError
from datagen.families.navigation.episode import plan_episode
from datagen.families.navigation.produce import produce
from datagen.families.navigation.values import draw_nav_scene
from datagen.families.navigation.world import NAV_CLASS_ID, build_nav_scene
from datagen.registries import GROUND_ROBOTS
from datagen.sensing.render import capture

CAR = "configs/nav_plus_maze_car.yaml"
FETCH = "configs/nav_maze.yaml"
ASPECTS = ((128, 96), (160, 80), (72, 120))  # 4:3, 2:1, 3:5 (pixels)


def _decode(data: bytes) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)


def _own_pixels(config, camera: dict, steer: float = 0.0) -> int:
    """Pixels of the robot's own instance in one frame from the middle of episode 0."""
    episode = plan_episode(config.navigation, 0, 0)
    values = draw_nav_scene(config, 0, 0, episode.layout) | {"camera": camera}
    scene = build_nav_scene(config, episode, values)
    poses = episode.trajectory.poses
    scene.set_base(*poses[len(poses) // 2], steer)
    scene.scene.update_render()
    instance, _ = scene.label_maps(capture(scene.camera).entity_ids)
    return int((instance == scene.things[-1].instance_id).sum())


def _sized(path: str, width: int, height: int):
    config = load_config(path)
    return config.replace(render=RenderConfig(width=width, height=height, far=20.0))


@pytest.mark.sim
def test_no_frame_of_many_car_episodes_shows_the_car_itself():
    """12 episodes of one car and 2 of two (each camera): no pixel of its own instance, and no
    pixel of class car where only one car drives."""
    config = _sized(CAR, 96, 72)
    two = config.replace(navigation=dataclasses.replace(config.navigation, robots=2))
    frames = 0
    for cfg, indices in ((config, range(12)), (two, range(2))):
        for index in indices:
            sample = produce(cfg, 0, index)
            meta = json.loads(sample.parts["json"])
            cars = [t["instance_id"] for t in meta["things"] if t["class"] == "car"]
            for name, data in sample.parts.items():
                if name.endswith(".seg.png"):
                    camera = int(name.split(".r")[1][0]) if ".r" in name else 0
                    assert not (_decode(data) == cars[camera]).any(), (index, name)
                    frames += 1
                if name.endswith(".semantic.png") and len(cars) == 1:
                    assert not (_decode(data) == NAV_CLASS_ID["car"]).any(), (index, name)
    assert frames > 150


@pytest.mark.sim
@pytest.mark.parametrize(("width", "height"), ASPECTS)
def test_the_car_misses_itself_at_the_extremes_of_its_view(width, height):
    config = _sized(CAR, width, height)
    nav = config.navigation
    shipped = [(p, f) for p in nav.camera_pitch_deg for f in nav.camera_fovy_deg]
    limit = GROUND_ROBOTS["car"].view_limit_deg
    edges = [(limit - 35, 70), (35 - limit, 70), (limit - 5, 10), (limit - 75, 150)]
    for pitch, fovy in [*shipped, *edges]:
        for steer in (-1.0, 1.0):  # radians: beyond any steering limit
            camera = {"torso_lift": 0.0, "pitch_deg": pitch, "fovy_deg": fovy}
            assert _own_pixels(config, camera, steer) == 0, (pitch, fovy, steer)
    beyond = {"torso_lift": 0.0, "pitch_deg": limit - 15, "fovy_deg": 70}  # 110 degrees down
    assert _own_pixels(config, beyond) > 0


@pytest.mark.sim
@pytest.mark.parametrize(("width", "height"), ASPECTS)
def test_fetch_misses_itself_at_the_extremes_of_its_view(width, height):
    config = _sized(FETCH, width, height)
    for fovy in (10, 50, 70, 110, 150):
        for lift in (0.0, 0.386):  # the torso's range, metres
            pitch = GROUND_ROBOTS["fetch"].view_limit_deg - fovy / 2
            camera = {"torso_lift": lift, "pitch_deg": pitch, "fovy_deg": fovy}
            assert _own_pixels(config, camera) == 0, camera
    beyond = {
        "torso_lift": 0.0,
        "pitch_deg": GROUND_ROBOTS["fetch"].view_limit_deg,
        "fovy_deg": 10,
    }  # 80 down
    assert _own_pixels(config, beyond) > 0


@pytest.mark.parametrize(
    ("navigation", "reach"),
    [
        ({"robot": "car", "camera_pitch_deg": [0, 60], "camera_fovy_deg": [50, 70]}, "95"),
        ({"robot": "car", "camera_pitch_deg": [-60, 0], "camera_fovy_deg": [50, 70]}, "95"),
        ({"robot": "fetch", "camera_pitch_deg": [5, 45], "camera_fovy_deg": [50, 70]}, "80"),
    ],
)
def test_a_view_that_would_see_the_robot_is_refused_naming_the_key(navigation, reach):
    with pytest.raises(ConfigError) as info:
        config_from_dict({"scene": "navigation", "navigation": navigation})
    message = str(info.value)
    assert "navigation.camera_pitch_deg" in message and f"reach {reach} degrees" in message
    assert len(message.splitlines()) == 1
    fine = {**navigation, "camera_pitch_deg": [0, 20]}
    config_from_dict({"scene": "navigation", "navigation": fine})
