"""The episodes inside a dataset, whatever their scene family: what the policy-learning exports
(LeRobot, robomimic) write, one :class:`Episode` per sample that holds one.

An episode is a sequence of T frames at a fixed rate ``fps``: frame t is at exactly ``t / fps``
seconds, its state and the action commanded from it on, and the sample's image parts that show
it, per camera. Which samples hold one, and how they map:

- a recorded grasp attempt (scene ``grasp_attempts``, part ``trajectory.npz``): frames are the
  filmed frames (``campaign.frame_hz``; cameras ``workspace`` and, with the wrist camera,
  ``wrist``) at the recorded rows of the same steps, so ``frame_hz`` must divide ``record_hz``
  (e.g. equal it); an attempt filmed at no rate gives its rows without cameras. State: the joint
  positions (arm, then fingers); action: the commanded arm joint targets and finger target. An
  attempt that found no candidate (no ``trajectory.npz``) holds no episode. The final row, taken
  after the hold off the rate's grid, is left out.
- a navigation episode (scene ``navigation``): its frames at ``navigation.frame_rate_hz``,
  camera ``head`` with depth; state: x, y (m), yaw (rad); action: what takes frame t to frame
  t + 1, the k = control_rate_hz / frame_rate_hz commands of the control steps between them, each
  held for one control step (``step0.linear_m_s``, ``step0.angular_rad_s``, ``step1...``: (v m/s,
  w rad/s) for Fetch, (v m/s, steering angle rad) for the car; (0, 0) once the robot stands at its
  goal), from the stored control-rate trajectory. The final frame, rendered at the goal off the
  rate's grid, is left out when it is off the grid.
- a navigation episode of several robots (``navigation.robots`` > 1): one episode per robot (key
  ``<sample>.r<k>``), as a single robot's, its camera ``r<k>`` named ``head``.
- an aerial episode (scene ``aerial``): one episode per drone (key ``<sample>.d<k>``), its frames
  at ``aerial.frame_rate_hz`` from its cameras, named by role (``forward``: part ``d<k>``;
  ``down``: ``d<k>_down``, if built) with depth; state: position (m), attitude quaternion x, y, z, w and velocity (m/s) in the world;
  action: the collective thrust (m/s², mass-normalised) and body rates (rad/s) the expert flies
  with; the final frame off the rate's grid is left out.

Anything else (frames-only scenes) holds none: :func:`require_episodes` says so in one line.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from datagen.dataset.loader import DatasetError, decode_parts
from datagen.dataset.trajectory import decode_trajectory
from datagen.dataset.values import BadSample, shown
from datagen.dataset.views import labelled_views
from datagen.exports.checks import finite_in_float32, finite_rate, sample_metadata
from datagen.records import ExportedDataset, Manifest
from datagen.registries import FAMILIES

GRID_TOLERANCE_S = 1e-6  # a frame's time within this of t / fps is on the rate's grid
MAX_STEPS_PER_FRAME = 10_000  # control steps between two frames: the config's 100 Hz / 0.01 Hz


@dataclass
class Episode:
    key: str  # the sample's key
    kind: str  # "grasp", "navigation" or "aerial"
    task: str  # in words: "pick up the mug", "drive to the goal through the corridor"
    fps: float  # Hz
    state: np.ndarray  # (T, S) float32
    state_names: list[str]
    action: np.ndarray  # (T, A) float32
    action_names: list[str]
    success: bool
    cameras: dict[str, list[str]]  # camera -> the sample's colour PNG part of each frame
    depth: dict[str, list[str]] = field(default_factory=dict)  # camera -> 16-bit mm PNG parts
    extras: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (T, ...) per frame
    extra_names: dict[str, list[str]] = field(default_factory=dict)  # its columns, if named
    robot: str = ""  # the robot of a navigation episode ("fetch", "car"); "" where the kind says

    @property
    def length(self) -> int:
        return len(self.state)

    @property
    def timestamps(self) -> np.ndarray:
        """(T,) float32 seconds, exactly ``frame_index / fps``."""
        return (np.arange(self.length) / self.fps).astype(np.float32)

    @property
    def reward(self) -> np.ndarray:
        """(T,) float32: 1 on the last frame of a successful episode, else 0 (sparse)."""
        reward = np.zeros(self.length, np.float32)
        reward[-1] = float(self.success)
        return reward

    @property
    def done(self) -> np.ndarray:
        """(T,) bool: True on the last frame."""
        done = np.zeros(self.length, bool)
        done[-1] = True
        return done

    def features(self) -> list[tuple[str, np.ndarray, list[str] | None]]:
        """(LeRobot's feature name, (T, ...) values, column names) of its numbers per frame."""
        return [
            ("observation.state", self.state, self.state_names),
            ("action", self.action, self.action_names),
            *((f"observation.{k}", v, self.extra_names.get(k)) for k, v in self.extras.items()),
        ]

    def parts(self) -> set[str]:
        """Every image part the episode's frames refer to."""
        return {p for names in (*self.cameras.values(), *self.depth.values()) for p in names}


def require_episodes(manifest: Manifest, root: object, format_name: str) -> None:
    """DatasetError in one line unless the dataset's scene family makes episodes."""
    scene = manifest.get("scene")
    family = FAMILIES.get(scene) if isinstance(scene, str) else None
    if family is None or not family.episodes:
        makers = " or ".join(name for name in FAMILIES if FAMILIES[name].episodes)
        raise DatasetError(
            f"{root}: cannot export {format_name!r}: it stores episodes (states, actions, camera "
            f"frames over time) and scene {scene!r} makes single frames; episodes come from "
            f"{makers} scenes (docs/exports.md)"
        )


def episodes(dataset: ExportedDataset, manifest: Manifest) -> Iterator[tuple[int, Episode]]:
    """(sample position, episode) for each episode a sample holds, in the dataset's order; one
    sample's metadata and trajectory in memory at a time (images are read by the caller)."""
    for i in range(len(dataset)):
        for episode in episodes_of(dataset, manifest, i):
            yield i, episode


def episodes_of(dataset: ExportedDataset, manifest: Manifest, i: int) -> list[Episode]:
    """The episodes sample ``i`` holds: none, one, or one per drone of an aerial episode; each
    checked to hold finite float32 values at a rate (BadSample naming the feature otherwise)."""
    found = _episodes_of(dataset, manifest, i)
    for episode in found:
        finite_rate(episode.fps, "its episode's frame rate")
        for feature, values, names in episode.features():
            finite_in_float32(values, feature, names)
    return found


def _episodes_of(dataset: ExportedDataset, manifest: Manifest, i: int) -> list[Episode]:
    meta = sample_metadata(dataset, i)
    if meta.get("format") == "datagen.nav_episode/1":
        return [_navigation(meta, float(manifest["config"]["navigation"]["frame_rate_hz"]))]
    if meta.get("format") == "datagen.nav_fleet/1":
        fps = float(manifest["config"]["navigation"]["frame_rate_hz"])
        return [_ground_agent(meta, fps, k) for k in range(len(meta["episode"]["agents"]))]
    if meta.get("format") == "datagen.aerial_episode/1":
        fps = float(manifest["config"]["aerial"]["frame_rate_hz"])
        return [_aerial(meta, fps, k) for k in range(len(meta["episode"]["agents"]))]
    if isinstance(meta.get("attempt"), dict):
        names = set(dataset.part_names(i))
        if "trajectory.npz" not in names:
            return []
        raw = dataset.raw(i, {"trajectory.npz"})
        return [_grasp(meta, decode_trajectory(raw["trajectory.npz"]), names)]
    return []


def frames_of(raw: dict[str, bytes], parts: list[str]) -> np.ndarray:
    """The images of ``parts`` decoded and stacked: (T, H, W, 3) uint8 RGB or (T, H, W) uint16."""
    decoded = []
    for part in parts:
        kind = "depth" if part.endswith("depth.png") else "rgb"
        decoded.append(decode_parts({f"{kind}.png": raw[part]})[kind])
    return np.stack(decoded)


def _words(name: str) -> str:
    return name.replace("_", " ")


def _grasp(meta: dict[str, Any], traj: dict[str, Any], part_names: set[str]) -> Episode:
    names, key = traj["names"], meta["key"]
    timestep = float(names["timestep"])
    row_every, frame_every = int(names["row_every_steps"]), int(names["frame_every_steps"] or 0)
    steps = traj["step"]
    if len(traj["frame_step"]):
        if frame_every % row_every:
            raise DatasetError(
                f"sample {key}: frames every {frame_every} physics steps do not fall on the "
                f"state rows (every {row_every}): build with campaign.frame_hz equal to "
                f"campaign.record_hz (or a divisor of it)"
            )
        rows = np.searchsorted(steps, traj["frame_step"])
        fps = 1.0 / (frame_every * timestep)
        cameras = {"workspace": [f"frame{k}.rgb.png" for k in range(len(rows))]}
        wrist = [f"frame{k}.wrist.rgb.png" for k in range(len(rows))]
        if all(p in part_names for p in wrist):
            cameras["wrist"] = wrist
    else:
        rows = np.flatnonzero(steps % row_every == 0)  # the last row, after the hold, is off it
        fps, cameras = 1.0 / (row_every * timestep), {}
    attempt = meta["attempt"]
    return Episode(
        key=key,
        kind="grasp",
        task=f"pick up the {_words(attempt['target']['class'])}",
        fps=fps,
        state=traj["qpos"][rows].astype(np.float32),
        state_names=list(names["joint_names"]),
        action=traj["action"][rows].astype(np.float32),
        action_names=list(names["action_names"]),
        success=bool(attempt["outcome"]["success"]),
        cameras=cameras,
        extras={
            "gripper_opening": traj["gripper_opening"][rows, None],  # m
            "tcp_pose": traj["tcp_pose"][rows],  # world xyz m, quaternion wxyz
            "target_pose": traj["target_pose"][rows],
            "qvel": traj["qvel"][rows],
            "phase": traj["phase"][rows, None].astype(np.int64),
        },
        extra_names={
            "gripper_opening": ["opening_m"],
            "tcp_pose": ["x", "y", "z", "qw", "qx", "qy", "qz"],
            "target_pose": ["x", "y", "z", "qw", "qx", "qy", "qz"],
            "qvel": list(names["joint_names"]),
            "phase": ["phase"],
        },
    )


def _on_grid(records: list[dict[str, Any]], fps: float) -> list[int]:
    """Indices of the records whose time is on the ``fps`` grid (frame n at n / fps)."""
    return [
        n
        for n, record in enumerate(records)
        if abs(float(record["time_s"]) - n / fps) <= GRID_TOLERANCE_S
    ]


def held_commands(commands: np.ndarray, first: int, count: int) -> np.ndarray:
    """(count, 2): the commands of control steps ``first`` .. ``first + count - 1`` of a
    trajectory, (0, 0) for the steps before its first or after its last (the robot stands)."""
    steps = np.arange(first, first + count)
    held = np.zeros((count, 2))
    inside = (steps >= 0) & (steps < len(commands))
    held[inside] = commands[steps[inside]]
    return held


def _frame_actions(
    trajectory: dict[str, Any], records: list[dict[str, Any]], fps: float, delay: float, where: str
) -> np.ndarray:
    """(T, 2k) float32: per frame, the k commands that take it to the next frame on the ``fps``
    grid (the trajectory's commands from the frame's step on, the robot waiting ``delay``
    seconds at its start first); ``where``: the trajectory's key, for messages."""
    dt = trajectory.get("dt")
    per_frame = 1.0 / (fps * dt) if isinstance(dt, int | float) and dt > 0 else math.nan
    every = round(per_frame) if 1 <= per_frame <= MAX_STEPS_PER_FRAME else 0
    if not every or abs(every - per_frame) > 1e-6 * every:
        raise BadSample(
            f"{where}.dt: frames at {fps:g} Hz fall every "
            f"{per_frame:g} control steps of {shown(dt)} s; expected a whole number from 1 to "
            f"{MAX_STEPS_PER_FRAME} (navigation.frame_rate_hz dividing control_rate_hz)"
        )
    commands = _commands(trajectory.get("commands"), where)
    waited = round(delay / dt)
    return np.stack(
        [held_commands(commands, int(r["step"]) - waited, every).ravel() for r in records]
    ).astype(np.float32)


def _commands(value: Any, where: str) -> np.ndarray:
    """(S, 2) float: a stored trajectory's commands."""
    try:
        commands = np.asarray(value if value else np.zeros((0, 2)), float)
    except (TypeError, ValueError):
        commands = np.zeros(0)
    if commands.ndim != 2 or commands.shape[1] != 2:
        raise BadSample(f"{where}.commands: expected (steps, 2) numbers")
    return commands


def _ground(
    meta: dict[str, Any],
    fps: float,
    key: str,
    states: list[dict[str, Any]],
    success: bool,
    prefixes: list[str],
    action: np.ndarray,
) -> Episode:
    """A ground robot's episode from its per-frame states, its frames' part prefixes and the
    actions that take each frame to the next."""
    names = list(meta["robot"].get("commands", ["linear_m_s", "angular_rad_s"]))
    steps = action.shape[1] // len(names)
    return Episode(
        key=key,
        kind="navigation",
        task=f"drive to the goal through the {_words(meta['family'])}",
        robot=str(meta["robot"].get("name", "")),
        fps=fps,
        state=np.array([s["pose"] for s in states], np.float32),
        state_names=["x", "y", "yaw"],
        action=action,
        # (v, w) for Fetch, (v, steering angle) for the car, per control step to the next frame
        action_names=[f"step{j}.{name}" for j in range(steps) for name in names],
        success=success,
        cameras={"head": [f"{p}rgb.png" for p in prefixes]},
        depth={"head": [f"{p}depth.png" for p in prefixes]},
        extras={
            "goal_in_robot": np.array([s["goal_in_robot"] for s in states], np.float32),
            "distance_to_goal": np.array([[s["distance_to_goal"]] for s in states], np.float32),
            "collision": np.array([[s["collision"]] for s in states], np.bool_),
        },
        extra_names={
            "goal_in_robot": ["x_m", "y_m"],
            "distance_to_goal": ["metres"],
            "collision": ["collision"],
        },
    )


def _navigation(meta: dict[str, Any], fps: float) -> Episode:
    views = labelled_views(meta)
    views = [views[n] for n in _on_grid([v.record for v in views], fps)]
    records = [v.record for v in views]
    trajectory = meta["episode"]["trajectory"]
    action = _frame_actions(trajectory, records, fps, 0.0, "episode.trajectory")
    return _ground(
        meta,
        fps,
        meta["key"],
        records,
        bool(meta["episode"]["success"]),
        [v.prefix for v in views],
        action,
    )


def _aerial(meta: dict[str, Any], fps: float, k: int) -> Episode:
    records = [meta["frames"][n] for n in _on_grid(meta["frames"], fps)]
    states = [r["agents"][k] for r in records]
    # by role, not by drone: every drone's episode has the same features
    roles = {
        c.removeprefix(f"d{k}").lstrip("_") or "forward": c
        for c, record in meta["cameras"].items()
        if record["drone"] == k
    }
    frames = [f"f{r['frame']:04d}" for r in records]
    agent = meta["episode"]["agents"][k]
    return Episode(
        key=f"{meta['key']}.d{k}",
        kind="aerial",
        task=f"fly to the goal through the {_words(meta['family'])}",
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


def _ground_agent(meta: dict[str, Any], fps: float, k: int) -> Episode:
    """Robot ``k`` of a ``datagen.nav_fleet/1`` episode, as a single robot's episode."""
    records = [meta["frames"][n] for n in _on_grid(meta["frames"], fps)]
    agent, key = meta["episode"]["agents"][k], f"{meta['key']}.r{k}"
    where = f"episode.agents[{k}].trajectory"
    action = _frame_actions(agent["trajectory"], records, fps, float(agent["delay_s"]), where)
    return _ground(
        meta,
        fps,
        key,
        [r["agents"][k] for r in records],
        bool(agent["success"]),
        [f"f{r['frame']:04d}.r{k}." for r in records],
        action,
    )
