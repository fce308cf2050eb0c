"""Episode ``index`` of a navigation build: plan, build the scene, drive Fetch along the expert
trajectory and render its head camera at the frame rate; one sample per episode.

Parts: ``fNNNN.rgb.png fNNNN.depth.png fNNNN.seg.png fNNNN.semantic.png`` per frame (NNNN = frame
number from 0), ``map.png`` (top-down picture with the paths), ``occupancy.png`` (the grid, one
pixel per cell, 255 = occupied) and ``json`` (see docs/navigation.md).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from datagen.config import BuildConfig
from datagen.config.sections import RenderConfig
from datagen.exports.episodes import held_commands
from datagen.families.navigation.episode import Episode, car_params, frame_steps, plan_episode
from datagen.families.navigation.map_image import episode_map, occupancy_image
from datagen.families.navigation.planning import clearance
from datagen.families.navigation.values import draw_nav_scene
from datagen.families.navigation.world import NAV_CLASSES, NavScene, build_nav_scene
from datagen.floorplans.grid import Layout, inflate
from datagen.outcomes import spl
from datagen.registries import GROUND_ROBOTS
from datagen.registry import resolve
from datagen.sample import Sample
from datagen.scene_values.checks import as_json
from datagen.scene_values.rounding import rounded
from datagen.sensing.camera_record import camera_record
from datagen.sensing.encode import (
    POSE_CONVENTION,
    View,
    encode_view,
    metadata_bytes,
    png_bytes,
    pose_file,
)
from datagen.sensing.render import capture, keep_renderer_alive
from datagen.worlds.robots import FETCH
from datagen.worlds.things import episode_header, things_in_view

NAV_FORMAT = "datagen.nav_episode/1"


def frame_prefix(frame: int) -> str:
    return f"f{frame:04d}."


def planar_pose(x: float, y: float, yaw: float) -> np.ndarray:
    """4x4 world pose of the robot frame: origin on the floor under the base, x forward."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0, x], [s, c, 0, y], [0, 0, 1, 0], [0, 0, 0, 1]], float)


def render_episode(
    config: BuildConfig, episode: Episode, scene: NavScene, steps: list[int]
) -> tuple[dict[str, bytes], list[dict[str, Any]], dict[str, Any]]:
    """Encoded frame parts, per-frame records and the camera record."""
    traj = episode.trajectory
    every = round(1.0 / (config.navigation.frame_rate_hz * traj.dt))  # control steps per frame
    parts: dict[str, bytes] = {}
    records, extrinsics = [], []
    camera_in_robot = None
    steers = GROUND_ROBOTS[config.navigation.robot].steers  # the robot's record, once
    unlisted = robot_labels()
    for k, step in enumerate(steps):
        x, y, yaw = (float(v) for v in traj.poses[step])
        command = traj.commands[step] if step < len(traj.commands) else (0.0, 0.0)
        steer = float(command[1]) if steers else 0.0
        scene.set_base(x, y, yaw, steer)
        scene.scene.update_render()
        frame = capture(scene.camera)
        instance, semantic = scene.label_maps(frame.entity_ids)
        view = View(frame.rgb, frame.depth, instance, semantic)
        parts |= encode_view(view, frame_prefix(k), config.output.png_level)
        extrinsics.append(frame.extrinsics)
        if camera_in_robot is None:  # fixed mount: the same in every frame
            camera_in_robot = np.linalg.inv(planar_pose(x, y, yaw)) @ np.linalg.inv(
                frame.extrinsics
            )
            intrinsics = frame.intrinsics
        records.append(
            {
                "frame": k,
                "step": step,
                "time_s": round(step * traj.dt, 6),
                "pose": rounded([x, y, yaw]),
                "command": rounded(command),
                "action": rounded(held_commands(traj.commands, step, every)),  # to the next frame
                "goal_in_robot": rounded(traj.goal_in_robot[step]),
                "distance_to_goal": round(float(traj.distance_to_goal[step]), 6),
                # metres between the robot's footprint disk and the nearest wall or obstacle
                "obstacle_gap": round(
                    clearance(episode.layout.grid, episode.layout.resolution, x, y)
                    - config.navigation.robot_radius,
                    6,
                ),
                "collision": bool(traj.collision[step]),
                "extrinsics_world_to_camera": rounded(frame.extrinsics, 7),
                "things": things_in_view(scene.things, instance, skip=unlisted),
            }
        )
    assert camera_in_robot is not None  # set at the first frame
    camera = robot_camera_record(config.render, scene.camera.fovy, camera_in_robot, intrinsics)
    parts["poses.head.txt"] = pose_file(extrinsics)
    return parts, records, camera


def episode_record(config: BuildConfig, episode: Episode, steps: list[int]) -> dict[str, Any]:
    traj, layout = episode.trajectory, episode.layout
    shortest, travelled = episode.shortest_path_m, episode.travelled_m
    return {
        "success": bool(traj.success),
        "path_length_m": round(travelled, 6),
        "shortest_path_m": round(shortest, 6),
        "planned_path_m": round(episode.planned_path_m, 6),
        "astar_path_m": round(episode.astar_length_m, 6),
        "spl": spl(traj.success, shortest, travelled),
        "steps": len(traj.commands),
        "duration_s": round(len(traj.commands) * traj.dt, 6),
        "frames": len(steps),
        "collision_steps": int(traj.collision.sum()),
        "start": rounded(episode.start),
        "goal": rounded(episode.goal),
        "start_cell": list(episode.start_cell),
        "goal_cell": list(episode.goal_cell),
        "inflation_m": round(episode.inflation, 6),
        "planned_path": rounded(episode.path, 5),
        "trajectory": traj.to_dict(),
        "layout": layout_record(layout),
    }


def robot_camera_record(
    render: RenderConfig, fovy: float, camera_in_robot: np.ndarray, intrinsics: np.ndarray
) -> dict[str, Any]:
    """A robot camera's record: its image, lens and fixed mount (``fovy`` in radians)."""
    forward = camera_in_robot[:3, 2]  # OpenCV z axis = viewing direction
    mount = {
        "camera_in_robot": rounded(camera_in_robot, 7),
        "height_m": round(float(camera_in_robot[2, 3]), 6),
        "pitch_down_deg": round(math.degrees(-math.asin(float(forward[2]))), 6),
    }
    r = render
    return camera_record(r.width, r.height, fovy, r.near, r.far, intrinsics, mount)


def layout_record(layout: Layout) -> dict[str, Any]:
    return {
        "family": layout.family,
        "resolution": layout.resolution,
        "size_m": rounded(layout.size_m),
        "grid_shape": list(layout.grid.shape),
        "walls": [list(w) for w in layout.walls],
        "doors": [list(d) for d in layout.doors],
        "obstacles": [list(o) for o in layout.obstacles],
        "params": layout.params,
    }


def robot_labels() -> tuple[str, ...]:
    """The semantic classes of robots: a robot's camera does not list robots it sees."""
    return tuple(sorted({robot.label for robot in GROUND_ROBOTS.values()}))


def robot_record(config: BuildConfig, scene: NavScene) -> dict[str, Any]:
    """The sample's ``robot`` record, by the robot's own ``describe``."""
    return resolve(GROUND_ROBOTS[config.navigation.robot].describe)(config, scene)


def car_record(config: BuildConfig, scene: NavScene) -> dict[str, Any]:
    nav = config.navigation
    params = car_params(nav)
    return {
        "name": "car",
        "radius": nav.robot_radius,
        "wheelbase_m": round(params.wheelbase, 6),
        # the pose is the body's centre (the footprint disk's); the rear axle is behind it
        "rear_axle_behind_m": round(params.rear, 6),
        "max_steering_deg": nav.max_steering_deg,
        "min_turning_radius_m": round(params.min_turning_radius, 6),  # the rear axle's
        "min_centre_turning_radius_m": round(params.min_centre_turning_radius, 6),
        "commands": ["linear_m_s", "steering_rad"],
    }


def fetch_record(config: BuildConfig, scene: NavScene) -> dict[str, Any]:
    return {
        "name": "fetch",
        "description": f"mani_skill/assets/{FETCH}",
        "radius": config.navigation.robot_radius,
        "qpos_fixed": rounded(scene.robot.get_qpos()[3:]),
        "joints": [j.name for j in scene.robot.get_active_joints()],
        "commands": ["linear_m_s", "angular_rad_s"],
    }


def produce(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> Sample:
    """One robot's episode, in named steps as a ManiSkill task names its hooks: plan the path
    (:func:`plan_episode`), draw the values (:func:`draw_nav_scene`), build the world
    (:func:`build_nav_scene`), drive and film it (:func:`render_episode`), record the sample
    (:func:`record_episode`)."""
    keep_renderer_alive()
    episode = plan_episode(config.navigation, seed, index, attempt)
    values = draw_nav_scene(config, seed, index, episode.layout, attempt)
    scene = build_nav_scene(config, episode, values)
    steps = frame_steps(episode.trajectory, config.navigation.frame_rate_hz)
    filmed = render_episode(config, episode, scene, steps)
    return record_episode(config, seed, index, episode, values, scene, steps, filmed)


def record_episode(
    config: BuildConfig,
    seed: int,
    index: int,
    episode: Episode,
    values: dict[str, Any],
    scene: NavScene,
    steps: list[int],
    filmed: tuple[dict[str, bytes], list[dict[str, Any]], dict[str, Any]],
) -> Sample:
    """The sample of a filmed episode: the frames' parts (``filmed``, :func:`render_episode`'s),
    the map, the occupancy and the metadata."""
    nav = config.navigation
    parts, frames, camera = filmed
    layout = episode.layout
    inflated = inflate(layout.grid, episode.inflation, layout.resolution)
    level = config.output.png_level
    parts["map.png"] = png_bytes(episode_map(episode, inflated, steps), level)
    parts["occupancy.png"] = png_bytes(occupancy_image(layout.grid), level)
    metadata = {
        **episode_header(
            NAV_FORMAT, index, seed, config.scene, nav.family, NAV_CLASSES, scene.things
        ),
        "episode": episode_record(config, episode, steps),
        "camera": camera,
        "frames": frames,
        "poses_convention": POSE_CONVENTION,
        "robot": robot_record(config, scene),
        "randomisation": as_json(values),
    }
    parts["json"] = metadata_bytes(metadata)
    return Sample(index, parts)
