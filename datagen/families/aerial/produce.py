"""Episode ``index`` of an aerial build: plan the volume and every drone's flight, build the scene,
fly the drones along their trajectories and render each drone's cameras at the frame rate; one
sample per episode.

Parts, per frame k (``fKKKK``) and camera (``d<drone>`` forward, ``d<drone>_down`` downward):
``fKKKK.<camera>.rgb.png depth.png seg.png semantic.png`` and, but for the last frame,
``fKKKK.<camera>.flow.png`` (optical flow to frame k+1, KITTI 16-bit encoding); per episode
``occupancy.npz`` (the voxel grid), ``map.png`` (top-down), ``side.png`` (side view),
``poses.<camera>.txt`` (OpenCV camera axes, world z up) and ``poses_ned.<camera>.txt``
(TartanAir's NED) camera poses, ``imu.d<k>.npz`` (drone k's IMU stream and trajectory,
:mod:`datagen.families.aerial.imu`) and ``json`` (docs/aerial.md).
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from datagen.config import BuildConfig
from datagen.dataset.flow_png import encode_kitti
from datagen.families.aerial.episode import (
    AerialEpisode,
    flown_length,
    path_lower_bound,
    plan_aerial_episode,
)
from datagen.families.aerial.flatness import quaternion_xyzw
from datagen.families.aerial.imu import IMU_PART, IMU_STREAM, imu_arrays, imu_metadata, npz_bytes
from datagen.families.aerial.pictures import side_view, top_down
from datagen.families.aerial.values import draw_aerial_scene
from datagen.families.aerial.volumes import box_distance
from datagen.families.aerial.world import AERIAL_CLASSES, AerialScene, build_aerial_scene
from datagen.outcomes import agents_outcome, spl
from datagen.sample import Sample
from datagen.scene_values.checks import as_json
from datagen.scene_values.rounding import rounded
from datagen.seeding import sample_rng
from datagen.sensing.camera_record import camera_record
from datagen.sensing.encode import (
    NED_POSE_CONVENTION,
    POSE_CONVENTION,
    View,
    encode_view,
    metadata_bytes,
    png_bytes,
    pose_file,
    pose_file_ned,
)
from datagen.sensing.optical_flow import flow_to_next
from datagen.sensing.render import DEPTH_SCALE, Frame, capture, keep_renderer_alive
from datagen.worlds.things import episode_header, things_in_view

AERIAL_FORMAT = "datagen.aerial_episode/1"


def frame_times(duration: float, rate_hz: float) -> np.ndarray:
    """Seconds of the rendered frames: every 1/rate from 0, and the episode's end."""
    times = np.arange(0.0, duration, 1.0 / rate_hz)
    return np.append(times, duration) if duration - times[-1] > 1e-9 else times


def _pose(position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = rotation, position
    return matrix


def _agent_record(
    episode: AerialEpisode, k: int, states, index: int, boxes: np.ndarray, tolerance: float
) -> dict[str, Any]:
    agent, limits = episode.agents[k], episode.limits[k]
    p, rotation = states.position[index], states.rotation[index]
    gap = float(box_distance(p[None], boxes)[0]) - limits.radius
    return {
        "position": rounded(p),
        "quaternion_xyzw": rounded(quaternion_xyzw(rotation[None])[0]),
        "velocity": rounded(states.velocity[index]),
        "acceleration": rounded(states.acceleration[index]),
        "body_rates": rounded(states.body_rates[index]),
        "thrust": round(float(states.thrust[index]), 6),
        "imu": {
            "accelerometer": rounded(states.specific_force[index]),
            "gyroscope": rounded(states.body_rates[index]),
        },
        "distance_to_goal": round(float(np.linalg.norm(agent.goal - p)), 6),
        "goal_in_body": rounded(rotation.T @ (agent.goal - p)),
        "obstacle_gap": round(gap, 6),
        "collision": gap < 0.0,
        "arrived": bool(np.linalg.norm(agent.goal - p) <= tolerance),
    }


def _stereo(camera: str, baseline: float) -> dict[str, Any]:
    """A right camera's pair: its left camera and the baseline (metres, along the left camera's
    x axis)."""
    if not camera.endswith("_right"):
        return {}
    return {"stereo": {"left": camera.removesuffix("_right"), "baseline_m": baseline}}


# (parts, per-frame records, each camera's world-to-camera poses, each drone's states)
Filmed = tuple[dict[str, bytes], list[dict[str, Any]], dict[str, list[np.ndarray]], list[Any]]


def render_frames(
    config: BuildConfig, episode: AerialEpisode, scene: AerialScene, times: np.ndarray
) -> Filmed:
    """Parts, per-frame records and each camera's pose lines, rendering every camera at every
    time (flow of frame k is written once frame k+1 is rendered)."""
    parts: dict[str, bytes] = {}
    records: list[dict[str, Any]] = []
    poses: dict[str, list[np.ndarray]] = {name: [] for name in scene.cameras}
    boxes = episode.volume.boxes()
    states = [agent.states(times) for agent in episode.agents]
    instance_of = {
        i: thing.instance_id
        for i, thing in enumerate(t for t in scene.things if t.class_name == "drone")
    }
    previous: dict[str, tuple[Frame, np.ndarray]] = {}
    level = config.output.png_level
    for f, t in enumerate(times):
        scene.pose_drones(
            np.stack([s.position[f] for s in states]), np.stack([s.rotation[f] for s in states])
        )
        scene.scene.update_render()
        record: dict[str, Any] = {
            "frame": f,
            "time_s": round(float(t), 6),
            "agents": [],
            "cameras": {},
        }
        for k in range(len(episode.agents)):
            record["agents"].append(
                _agent_record(episode, k, states[k], f, boxes, config.aerial.goal_tolerance)
            )
        for name, camera in scene.cameras.items():
            frame = capture(camera)
            instance, semantic = scene.label_maps(frame.entity_ids)
            parts |= encode_view(
                View(frame.rgb, frame.depth, instance, semantic), f"f{f:04d}.{name}.", level
            )
            poses[name].append(frame.extrinsics)
            record["cameras"][name] = {
                "extrinsics_world_to_camera": rounded(frame.extrinsics, 7),
                "things": things_in_view(scene.things, instance),
            }
            if config.aerial.optical_flow and name in previous:
                before, before_instance = previous[name]
                motions = {
                    instance_of[k]: _pose(s.position[f], s.rotation[f])
                    @ np.linalg.inv(_pose(s.position[f - 1], s.rotation[f - 1]))
                    for k, s in enumerate(states)
                }
                flow, valid = flow_to_next(
                    before.depth * DEPTH_SCALE,
                    before.intrinsics,
                    before.extrinsics,
                    frame.extrinsics,
                    frame.depth * DEPTH_SCALE,
                    before_instance,
                    motions,
                )
                parts[f"f{f - 1:04d}.{name}.flow.png"] = png_bytes(encode_kitti(flow, valid), level)
            previous[name] = (frame, instance)
        records.append(record)
    return parts, records, poses, states


def produce(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> Sample:
    """Episode ``index``, in named steps as a ManiSkill task names its hooks: plan the flights
    (:func:`plan_aerial_episode`), draw the values (:func:`draw_aerial_scene`), build the world
    (:func:`build_aerial_scene`), fly and film it (:func:`render_frames`), record the sample
    (:func:`record_episode`)."""
    keep_renderer_alive()
    episode = plan_aerial_episode(config.aerial, seed, index, attempt)
    volume = episode.volume
    values = draw_aerial_scene(
        config, seed, index, volume.layout, volume.height, len(episode.agents), attempt
    )
    scene = build_aerial_scene(config, episode, values)
    times = frame_times(episode.duration, config.aerial.frame_rate_hz)
    filmed = render_frames(config, episode, scene, times)
    return record_episode(config, seed, index, attempt, episode, values, scene, times, filmed)


def record_episode(
    config: BuildConfig,
    seed: int,
    index: int,
    attempt: int,
    episode: AerialEpisode,
    values: dict[str, Any],
    scene: AerialScene,
    times: np.ndarray,
    filmed: Filmed,
) -> Sample:
    """The sample of a flown episode: the frames' parts (``filmed``, :func:`render_frames`'), the
    pictures of the volume, its occupancy, the cameras' pose files, each drone's IMU (stream
    ``imu.<k>``) and the metadata."""
    cfg, volume = config.aerial, episode.volume
    parts, frames, poses, states = filmed
    level = config.output.png_level
    parts["map.png"] = png_bytes(top_down(volume, episode.agents)[..., ::-1].copy(), level)
    parts["side.png"] = png_bytes(side_view(volume, episode.agents)[..., ::-1].copy(), level)
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer,
        occupancy=np.packbits(volume.occupancy, axis=None),
        shape=np.asarray(volume.shape),
        resolution=np.float64(volume.resolution),
    )
    parts["occupancy.npz"] = buffer.getvalue()
    for name, extrinsics in poses.items():
        parts[f"poses.{name}.txt"] = pose_file(extrinsics)
        parts[f"poses_ned.{name}.txt"] = pose_file_ned(extrinsics)
    for k, agent in enumerate(episode.agents):
        rng = sample_rng(seed, index, IMU_STREAM.format(k=k), attempt)
        arrays = imu_arrays(agent, cfg.imu_hz, episode.duration, cfg.imu_noise, rng)
        parts[IMU_PART.format(k=k)] = npz_bytes(arrays)
    agents = []
    for k, (agent, limits) in enumerate(zip(episode.agents, episode.limits, strict=True)):
        flown = flown_length(agent)
        shortest = path_lower_bound(volume, agent, limits)
        success = bool(
            frames[-1]["agents"][k]["arrived"]
            and not any(r["agents"][k]["collision"] for r in frames)
        )
        agents.append(
            {
                "span_m": episode.shapes[k].span,
                "radius_m": round(limits.radius, 6),
                "start": rounded(agent.start),
                "goal": rounded(agent.goal),
                "take_off_s": round(agent.take_off, 6),
                "flight_s": round(agent.flight.duration, 6),
                "waypoints": rounded(agent.flight.waypoints, 5),
                "slow_down": round(agent.flight.slow_down, 6),
                "midpoints": agent.flight.splits,
                "success": success,
                "path_length_m": round(flown, 6),
                "shortest_path_m": round(shortest, 6),
                "spl": spl(success, shortest, flown),
                "max_speed": round(float(np.linalg.norm(states[k].velocity, axis=1).max()), 6),
                "altitude_m": [
                    round(float(states[k].position[:, 2].min()), 6),
                    round(float(states[k].position[:, 2].max()), 6),
                ],
            }
        )
    r = config.render
    metadata = {
        **episode_header(
            AERIAL_FORMAT, index, seed, config.scene, cfg.family, AERIAL_CLASSES, scene.things
        ),
        "episode": {
            # the episode as a whole (what inspect, the monitor and the exports read)
            **agents_outcome(agents),
            "duration_s": round(episode.duration, 6),
            "frames": len(times),
            "attempt": episode.attempt,
            "agents": agents,
            "volume": {
                "height": volume.height,
                "resolution": volume.resolution,
                "shape": list(volume.shape),
                "solids": [{"kind": s.kind, "box": list(s.box)} for s in volume.solids],
                "params": volume.params,
                "layout": {
                    "family": volume.layout.family,
                    "walls": [list(w) for w in volume.layout.walls],
                    "params": volume.layout.params,
                },
            },
        },
        "cameras": {
            name: camera_record(
                r.width,
                r.height,
                cam.fovy,
                r.near,
                r.far,
                cam.get_intrinsic_matrix(),
                {"camera_in_body": rounded(scene.camera_in_body[name], 7)},
            )
            | {"drone": int(name[1:].split("_")[0]), **_stereo(name, cfg.stereo_baseline)}
            for name, cam in scene.cameras.items()
        },
        "poses_convention": {
            "poses.<camera>.txt": POSE_CONVENTION,
            "poses_ned.<camera>.txt": NED_POSE_CONVENTION,
        },
        "imu": imu_metadata(cfg.imu_hz, cfg.imu_noise),
        "frames": frames,
        "randomisation": as_json(values),
    }
    parts["json"] = metadata_bytes(metadata)
    return Sample(index, parts)
