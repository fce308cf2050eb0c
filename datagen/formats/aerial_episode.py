"""``datagen.aerial_episode/1``: quadrotors flying one volume, each drone's cameras over time
(parts ``f0003.d0.rgb.png``, ``f0003.d0.flow.png``, ...; records in ``frames``), the drones'
states per frame, IMU streams (``imu.d0.npz``), camera poses (``poses.d0.txt``) and the
volume's pictures and voxels."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from datagen.dataset.episode_parts import (
    CAMERA_FRAMES,
    MAP_PICTURES,
    POSE_FILES,
    imu_stream,
    voxel_grid,
)
from datagen.dataset.part_rules import Decoding, PartRule
from datagen.dataset.views import camera_sequence_views
from datagen.exports.episodes import Episode, on_grid, words
from datagen.formats.counting import agent_fields, agents_summary
from datagen.records import ExportedDataset, Manifest, SampleMetadata
from datagen.tools.aerial_preview import aerial_tile

views = camera_sequence_views
tile = aerial_tile


def _imu(decoding: Decoding, match: re.Match[str], data: bytes) -> None:
    decoding.item.setdefault("imu", {})[match[1]] = imu_stream(data, match[0])


def _voxels(decoding: Decoding, match: re.Match[str], data: bytes) -> None:
    decoding.item["occupancy"], decoding.item["occupancy_resolution"] = voxel_grid(data)


# its cameras' frames and pose files, the top-down and side pictures, each drone's IMU stream
# (imu.d0.npz) and the voxel grid (occupancy.npz)
PARTS = (
    CAMERA_FRAMES,
    POSE_FILES,
    MAP_PICTURES,
    PartRule(re.compile(r"imu\.(d\d+)\.npz"), _imu),
    PartRule(re.compile(r"occupancy\.npz"), _voxels),
)


def _agents(metas: Sequence[SampleMetadata]) -> list[dict[str, Any]]:
    return [a for m in metas for a in m["episode"]["agents"]]


def _states(metas: Sequence[SampleMetadata]) -> list[dict[str, Any]]:
    return [s for m in metas for f in m["frames"] for s in f["agents"]]


def distributions(metas: list[SampleMetadata]) -> dict[str, list[float]]:
    agents, states = _agents(metas), _states(metas)
    return {
        "path length (m)": [a["path_length_m"] for a in agents],
        "shortest path (m)": [a["shortest_path_m"] for a in agents],
        "SPL": [a["spl"] for a in agents],
        "flight time (s)": [a["flight_s"] for a in agents],
        "altitude (m)": [s["position"][2] for s in states],
        "speed (m/s)": [float(np.linalg.norm(s["velocity"])) for s in states],
        "drones per episode": [len(m["episode"]["agents"]) for m in metas],
        "frames per episode": [m["episode"]["frames"] for m in metas],
        "ceiling height (m)": [m["episode"]["volume"]["height"] for m in metas],
    }


def summary(metas: Sequence[SampleMetadata]) -> dict[str, Any]:
    agents, states = _agents(metas), _states(metas)
    speeds = [float(np.linalg.norm(s["velocity"])) for s in states]
    return (
        {"drones": len(agents)}
        | agents_summary(metas, agents)
        | {
            "altitude_m": [
                round(min(s["position"][2] for s in states), 3),
                round(max(s["position"][2] for s in states), 3),
            ],
            "mean_speed_m_s": round(float(np.mean(speeds)), 3),
            "max_speed_m_s": round(float(np.max(speeds)), 3),
        }
    )


def summary_fields(meta: SampleMetadata) -> SampleMetadata:
    return agent_fields(meta, ("position", "velocity"))  # type: ignore[return-value]


def episodes(
    meta: SampleMetadata, dataset: ExportedDataset, i: int, manifest: Manifest
) -> list[Episode]:
    """One episode per drone (key ``<sample>.d<k>``) at ``aerial.frame_rate_hz``."""
    aerial = manifest["config"]["aerial"]
    fps, airframe = float(aerial["frame_rate_hz"]), str(aerial.get("airframe", "quadrotor"))
    records = [meta["frames"][n] for n in on_grid(meta["frames"], fps)]
    drones = range(len(meta["episode"]["agents"]))
    return [_drone(meta, records, fps, k, airframe) for k in drones]


def _drone(
    meta: SampleMetadata, records: Sequence[Mapping[str, Any]], fps: float, k: int, airframe: str
) -> Episode:
    """Drone ``k``'s frames from its cameras, named by role (``forward``: part ``d<k>``;
    ``down``: ``d<k>_down``, if built) with depth; state: position (m), attitude quaternion
    x, y, z, w and velocity (m/s) in the world; action: the collective thrust (m/s²,
    mass-normalised) and body rates (rad/s) the expert flies with."""
    states = [r["agents"][k] for r in records]
    # by role, not by drone: every drone's episode has the same features
    cameras: Mapping[str, Mapping[str, Any]] = meta["cameras"]
    roles = {
        c.removeprefix(f"d{k}").lstrip("_") or "forward": c
        for c, record in cameras.items()
        if record["drone"] == k
    }
    frames = [f"f{r['frame']:04d}" for r in records]
    agent = meta["episode"]["agents"][k]
    return Episode(
        key=f"{meta['key']}.d{k}",
        kind="aerial",
        task=f"fly to the goal through the {words(meta['family'])}",
        robot=airframe,
        fps=fps,
        state=np.array(
            [[*s["position"], *s["quaternion_xyzw"], *s["velocity"]] for s in states], np.float32
        ),
        state_names=["x", "y", "z", "qx", "qy", "qz", "qw", "vx", "vy", "vz"],
        action=np.array([[s["thrust"], *s["body_rates"]] for s in states], np.float32),
        action_names=["thrust_m_s2", "roll_rate_rad_s", "pitch_rate_rad_s", "yaw_rate_rad_s"],
        success=bool(agent["success"]),
        cameras={role: [f"{f}.{c}.rgb.png" for f in frames] for role, c in sorted(roles.items())},
        depth={role: [f"{f}.{c}.depth.png" for f in frames] for role, c in sorted(roles.items())},
        extras={
            "goal_in_body": np.array([s["goal_in_body"] for s in states], np.float32),
            "distance_to_goal": np.array([[s["distance_to_goal"]] for s in states], np.float32),
            "imu": np.array(
                [[*s["imu"]["accelerometer"], *s["imu"]["gyroscope"]] for s in states], np.float32
            ),
            "obstacle_gap": np.array([[s["obstacle_gap"]] for s in states], np.float32),
            "collision": np.array([[s["collision"]] for s in states], np.bool_),
        },
        extra_names={
            "goal_in_body": ["x_m", "y_m", "z_m"],
            "distance_to_goal": ["metres"],
            "imu": ["ax_m_s2", "ay_m_s2", "az_m_s2", "wx_rad_s", "wy_rad_s", "wz_rad_s"],
            "obstacle_gap": ["metres"],
            "collision": ["collision"],
        },
    )
