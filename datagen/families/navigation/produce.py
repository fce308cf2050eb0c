"""Episode ``index`` of a navigation build with several robots (``navigation.robots`` > 1): plan
every robot's task and start time (:mod:`datagen.families.navigation.fleet`), build the floor plan with a
robot and a goal marker each, drive them along their expert trajectories and render every robot's
camera at the frame rate; one sample per episode, format ``datagen.nav_fleet/1``.

Parts, per frame k (``fKKKK``) and robot r (camera ``r<r>``):
``fKKKK.r<r>.rgb.png depth.png seg.png semantic.png``; per episode ``map.png`` (every robot's
planned path and trajectory), ``occupancy.png`` and ``json`` (docs/navigation.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from datagen.config import BuildConfig
from datagen.exports.episodes import held_commands
from datagen.families.navigation.fleet import FleetEpisode, plan_fleet_episode
from datagen.families.navigation.map_image import fleet_map, occupancy_image
from datagen.families.navigation.one_robot import (
    layout_record,
    planar_pose,
    robot_camera_record,
    robot_record,
)
from datagen.families.navigation.one_robot import produce as produce_one
from datagen.families.navigation.planning import clearance
from datagen.families.navigation.values import draw_nav_scene
from datagen.families.navigation.world import NAV_CLASSES, NavScene, build_floorplan_scene
from datagen.floorplans.grid import inflate
from datagen.outcomes import agents_outcome, spl
from datagen.registries import GROUND_ROBOTS
from datagen.sample import Sample
from datagen.scene_values.checks import as_json
from datagen.scene_values.rounding import rounded
from datagen.sensing.encode import (
    POSE_CONVENTION,
    View,
    encode_view,
    metadata_bytes,
    png_bytes,
    pose_file,
)
from datagen.sensing.render import capture, keep_renderer_alive
from datagen.worlds.things import episode_header, things_in_view

FLEET_FORMAT = "datagen.nav_fleet/1"


def _agent_states(
    fleet: FleetEpisode, step: int, radius: float, every: int
) -> list[dict[str, Any]]:
    """Each robot's state at control ``step``; its ``action``: the commands of the ``every``
    control steps to the next frame."""
    out = []
    layout = fleet.layout
    for agent in fleet.agents:
        traj, row = agent.episode.trajectory, int(agent.step_index(step))
        held = held_commands(traj.commands, step - agent.delay, every)
        out.append(
            {
                "pose": rounded(traj.poses[row]),
                "command": rounded(held[0]),
                "action": rounded(held),
                "goal_in_robot": rounded(traj.goal_in_robot[row]),
                "distance_to_goal": round(float(traj.distance_to_goal[row]), 6),
                "obstacle_gap": round(
                    clearance(layout.grid, layout.resolution, *traj.poses[row, :2]) - radius, 6
                ),
                "collision": bool(traj.collision[row]),
                "arrived": step >= agent.arrival,
            }
        )
    return out


def _agent_record(agent, dt: float) -> dict[str, Any]:
    episode, traj = agent.episode, agent.episode.trajectory
    shortest, travelled = episode.shortest_path_m, episode.travelled_m
    return {
        "start": rounded(episode.start),
        "goal": rounded(episode.goal),
        "delay_s": round(agent.delay * dt, 6),
        "success": bool(traj.success),
        "path_length_m": round(travelled, 6),
        "shortest_path_m": round(shortest, 6),
        "planned_path_m": round(episode.planned_path_m, 6),
        "spl": spl(traj.success, shortest, travelled),
        "collision_steps": int(traj.collision.sum()),
        "planned_path": rounded(episode.path, 5),
        "trajectory": traj.to_dict(),
    }


def produce(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> Sample:
    """The navigation family's sample: an episode of one robot (``navigation_episodes``) or, with
    ``navigation.robots`` > 1, of several."""
    if config.navigation.robots == 1:
        return produce_one(config, seed, index, attempt)
    return produce_fleet(config, seed, index, attempt)


def produce_fleet(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> Sample:
    """A fleet's episode, in named steps as a ManiSkill task names its hooks: plan the paths
    (:func:`plan_fleet_episode`), draw the values (:func:`draw_nav_scene`), build the world
    (:func:`build_floorplan_scene`), drive and film it (:func:`film_fleet`), record the sample
    (:func:`record_fleet`)."""
    keep_renderer_alive()
    fleet = plan_fleet_episode(config.navigation, seed, index, attempt)
    values = draw_nav_scene(config, seed, index, fleet.layout, attempt)
    goals = [a.episode.goal for a in fleet.agents]
    scene = build_floorplan_scene(config, fleet.layout, goals, values["cameras"], values)
    film = film_fleet(config, fleet, scene)
    return record_fleet(config, seed, index, fleet, values, scene, film)


@dataclass
class FleetFilm:
    """What driving and filming a fleet made: the simulation steps filmed, the frames' parts
    and records, each robot's camera mount (camera in robot, K) and world-to-camera poses."""

    steps: list[int]
    parts: dict[str, bytes]
    frames: list[dict[str, Any]]
    mounts: dict[int, tuple[np.ndarray, np.ndarray]]
    extrinsics: dict[int, list[np.ndarray]]


def film_fleet(config: BuildConfig, fleet: FleetEpisode, scene: NavScene) -> FleetFilm:
    """Drives every robot along its expert path and renders every robot's camera at the frame
    rate."""
    nav = config.navigation
    every = max(1, round(1.0 / (nav.frame_rate_hz * fleet.dt)))
    steps = sorted({*range(0, fleet.steps + 1, every), fleet.steps})
    parts: dict[str, bytes] = {}
    frames: list[dict[str, Any]] = []
    mounts: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # robot -> camera in robot, K
    extrinsics: dict[int, list[np.ndarray]] = {k: [] for k in range(len(scene.cameras))}
    level = config.output.png_level
    steers = GROUND_ROBOTS[nav.robot].steers  # the robot's record, once
    for f, step in enumerate(steps):
        states = _agent_states(fleet, step, nav.robot_radius, every)
        for k, state in enumerate(states):
            steer = state["command"][1] if steers else 0.0
            x, y, yaw = state["pose"]
            scene.set_base(x, y, yaw, steer, k=k)
        scene.scene.update_render()
        record: dict[str, Any] = {
            "frame": f,
            "step": step,
            "time_s": round(step * fleet.dt, 6),
            "agents": states,
            "cameras": {},
        }
        for k, camera in enumerate(scene.cameras):
            frame = capture(camera)
            instance, semantic = scene.label_maps(frame.entity_ids)
            extrinsics[k].append(frame.extrinsics)
            parts |= encode_view(
                View(frame.rgb, frame.depth, instance, semantic), f"f{f:04d}.r{k}.", level
            )
            mounts.setdefault(
                k,
                (
                    np.linalg.inv(planar_pose(*states[k]["pose"]))
                    @ np.linalg.inv(frame.extrinsics),
                    frame.intrinsics,
                ),
            )
            own = scene.things[len(scene.things) - len(fleet.agents) + k].instance_id
            seen = [t for t in things_in_view(scene.things, instance) if t["instance_id"] != own]
            record["cameras"][f"r{k}"] = {
                "extrinsics_world_to_camera": rounded(frame.extrinsics, 7),
                "things": seen,
            }
        frames.append(record)
    return FleetFilm(steps, parts, frames, mounts, extrinsics)


def record_fleet(
    config: BuildConfig,
    seed: int,
    index: int,
    fleet: FleetEpisode,
    values: dict[str, Any],
    scene: NavScene,
    film: FleetFilm,
) -> Sample:
    """The sample of a filmed fleet: the frames' parts, the map, the occupancy, each camera's
    pose file and the metadata."""
    nav, layout, level = config.navigation, fleet.layout, config.output.png_level
    steps, parts, frames, mounts, extrinsics = (
        film.steps,
        film.parts,
        film.frames,
        film.mounts,
        film.extrinsics,
    )
    inflated = inflate(layout.grid, nav.robot_radius + nav.planning_margin, layout.resolution)
    parts["map.png"] = png_bytes(
        fleet_map(layout, inflated, [a.episode for a in fleet.agents]), level
    )
    parts["occupancy.png"] = png_bytes(occupancy_image(layout.grid), level)
    for k, poses in extrinsics.items():
        parts[f"poses.r{k}.txt"] = pose_file(poses)
    cameras = {
        f"r{k}": robot_camera_record(config.render, camera.fovy, *mounts[k]) | {"robot": k}
        for k, camera in enumerate(scene.cameras)
    }
    agents = [_agent_record(a, fleet.dt) for a in fleet.agents]
    metadata = {
        **episode_header(
            FLEET_FORMAT, index, seed, config.scene, nav.family, NAV_CLASSES, scene.things
        ),
        "episode": {
            # the episode as a whole (what inspect, the monitor and the exports read)
            **agents_outcome(agents),
            "steps": fleet.steps,
            "duration_s": round(fleet.steps * fleet.dt, 6),
            "frames": len(steps),
            "agents": agents,
            "layout": layout_record(layout),
        },
        "cameras": cameras,
        "frames": frames,
        "poses_convention": POSE_CONVENTION,
        "robot": robot_record(config, scene),
        "randomisation": as_json(values),
    }
    parts["json"] = metadata_bytes(metadata)
    return Sample(index, parts)
