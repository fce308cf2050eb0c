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
Each sample's metadata format (``datagen.formats``) finds its episodes; what the ground robots'
formats share is here.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from datagen.dataset.loader import DatasetError
from datagen.dataset.parts import decode_parts
from datagen.dataset.values import BadSample, shown
from datagen.exports.checks import finite_in_float32, finite_rate, sample_metadata
from datagen.records import ExportedDataset, Manifest
from datagen.registries import FAMILIES, metadata_format

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
    robot: str = ""  # a navigation episode's robot ("fetch", "car"), an aerial one's airframe

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
    episodes_in = metadata_format(meta, f"sample {dataset.keys[i]}").function("episodes")
    return episodes_in(meta, dataset, i, manifest)


def frames_of(raw: dict[str, bytes], parts: list[str]) -> np.ndarray:
    """The images of ``parts`` decoded and stacked: (T, H, W, 3) uint8 RGB or (T, H, W) uint16."""
    decoded = []
    for part in parts:
        kind = "depth" if part.endswith("depth.png") else "rgb"
        decoded.append(decode_parts({f"{kind}.png": raw[part]})[kind])
    return np.stack(decoded)


def words(name: str) -> str:
    return name.replace("_", " ")


def on_grid(records: Sequence[Mapping[str, Any]], fps: float) -> list[int]:
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


def frame_actions(
    trajectory: Mapping[str, Any],
    records: Sequence[Mapping[str, Any]],
    fps: float,
    delay: float,
    where: str,
) -> np.ndarray:
    """(T, 2k) float32: per frame, the k commands that take it to the next frame on the ``fps``
    grid (the trajectory's commands from the frame's step on, the robot waiting ``delay``
    seconds at its start first); ``where``: the trajectory's key, for messages."""
    stored = trajectory.get("dt")
    dt = float(stored) if isinstance(stored, int | float) and stored > 0 else math.nan
    per_frame = 1.0 / (fps * dt)
    every = round(per_frame) if 1 <= per_frame <= MAX_STEPS_PER_FRAME else 0
    if not every or abs(every - per_frame) > 1e-6 * every:
        raise BadSample(
            f"{where}.dt: frames at {fps:g} Hz fall every "
            f"{per_frame:g} control steps of {shown(stored)} s; expected a whole number from 1 to "
            f"{MAX_STEPS_PER_FRAME} (navigation.frame_rate_hz dividing control_rate_hz)"
        )
    commands = commands_of(trajectory.get("commands"), where)
    waited = round(delay / dt)
    return np.stack(
        [held_commands(commands, int(r["step"]) - waited, every).ravel() for r in records]
    ).astype(np.float32)


def commands_of(value: Any, where: str) -> np.ndarray:
    """(S, 2) float: a stored trajectory's commands."""
    try:
        commands = np.asarray(value if value else np.zeros((0, 2)), float)
    except (TypeError, ValueError):
        commands = np.zeros(0)
    if commands.ndim != 2 or commands.shape[1] != 2:
        raise BadSample(f"{where}.commands: expected (steps, 2) numbers")
    return commands


def ground_episode(
    meta: Mapping[str, Any],
    fps: float,
    key: str,
    states: Sequence[Mapping[str, Any]],
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
        task=f"drive to the goal through the {words(meta['family'])}",
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
