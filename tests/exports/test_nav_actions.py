"""Navigation exports' actions take frame t to frame t + 1 at the export's rate (issue 39, item 8):
the exported commands of the control steps between two frames, integrated here by rotating about
each step's centre of rotation (the unicycle's, or the car's on its rear axle's line: independent
of datagen's arc formula), reach the next exported pose within 1 cm and 1 degree, for Fetch and
the car, one robot and fleets, in the LeRobot, robomimic and HDF5 exports."""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest
from adversarial.grasp_dataset import cli  # the in-process command line
from adversarial.hostile_exports import forged, navigation_source  # a real episode, then forged
from adversarial.refusals import refused
from conftest import write_dataset  # tests/conftest.py: a dataset written without the broker

import datagen
from datagen.config import config_from_dict
from datagen.exports.runner import run_exports
from datagen.families.navigation.produce import produce
from datagen.pipeline.manifest import build_manifest
from datagen.shards import write_json_durably

pytestmark = [pytest.mark.sim, pytest.mark.slow]
CAR = {"robot": "car", "robot_radius": 0.25, "lookahead": 0.7, "max_linear": 0.8}
CAR_CAMERA = {"camera_pitch_deg": [0, 20]}
BUILDS = {  # name: (navigation section, episodes)
    "fetch": ({"family": "maze"}, 3),
    "car": ({"family": "plus_maze", **CAR, **CAR_CAMERA, "clutter": [0, 0]}, 3),
    "fetch_fleet": ({"family": "corridor", "robots": 2}, 1),
    "car_fleet": ({"family": "plus_maze", "robots": 2, **CAR, **CAR_CAMERA}, 2),
}
POSITION_M, YAW_DEG = 0.01, 1.0


def _rotate(x: float, y: float, cx: float, cy: float, angle: float) -> tuple[float, float]:
    c, s = math.cos(angle), math.sin(angle)
    return cx + c * (x - cx) - s * (y - cy), cy + s * (x - cx) + c * (y - cy)


def unicycle(pose, v: float, w: float, dt: float):
    """(v m/s, w rad/s) held for dt: a turn of w dt about the point v / w to the left."""
    x, y, yaw = pose
    if abs(w) < 1e-12:
        return x + v * dt * math.cos(yaw), y + v * dt * math.sin(yaw), yaw
    radius = v / w
    cx, cy = x - radius * math.sin(yaw), y + radius * math.cos(yaw)
    return (*_rotate(x, y, cx, cy, w * dt), yaw + w * dt)


def bicycle(pose, v: float, steer: float, dt: float, wheelbase: float, rear: float):
    """The car's body centre at ``pose`` (the rear axle ``rear`` metres behind it), its speed v,
    the steering angle held for dt: a turn about the point on the rear axle's line at
    wheelbase / tan(steer), through which the centre runs v dt metres."""
    x, y, yaw = pose
    if abs(steer) < 1e-12:
        return x + v * dt * math.cos(yaw), y + v * dt * math.sin(yaw), yaw
    radius = wheelbase / math.tan(steer)  # signed: positive turns left
    ax, ay = x - rear * math.cos(yaw), y - rear * math.sin(yaw)
    cx, cy = ax - radius * math.sin(yaw), ay + radius * math.cos(yaw)
    angle = v * dt / math.hypot(radius, rear) * math.copysign(1.0, radius)
    return (*_rotate(x, y, cx, cy, angle), yaw + angle)


def misses(states: np.ndarray, actions: np.ndarray, fps: float, robot: dict) -> np.ndarray:
    """(T - 1, 2): per frame, metres and degrees between the pose its action reaches and the next
    frame's pose."""
    steps = actions.shape[1] // 2
    dt = 1.0 / fps / steps
    out = []
    for t in range(len(states) - 1):
        pose = tuple(float(v) for v in states[t])
        for v, u in actions[t].reshape(steps, 2).astype(float):
            if robot["name"] == "car":
                pose = bicycle(pose, v, u, dt, robot["wheelbase_m"], robot["rear_axle_behind_m"])
            else:
                pose = unicycle(pose, v, u, dt)
        yaw = (pose[2] - states[t + 1][2] + math.pi) % (2 * math.pi) - math.pi
        out.append((math.dist(pose[:2], states[t + 1][:2]), abs(math.degrees(yaw))))
    return np.array(out).reshape(-1, 2)


def _build(root: Path, navigation: dict, episodes: int) -> Path:
    render = {"width": 64, "height": 48, "far": 20.0}
    config = config_from_dict(
        {"scene": "navigation", "seed": 5, "num_samples": episodes, "render": render}
        | {"navigation": navigation}
    )
    write_dataset(root, [produce(config, 5, i) for i in range(episodes)])
    manifest = json.loads((root / "manifest.json").read_text())
    write_json_durably(root, manifest | build_manifest(config, "actions", 1))
    run_exports(root, ["lerobot", "robomimic", "hdf5"])
    return root


@pytest.fixture(scope="module")
def builds(tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("nav_actions")
    return {name: _build(tmp / name, *spec) for name, spec in BUILDS.items()}


def _lerobot(root: Path) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(datagen key, states, actions) per episode, as the parquet files hold them."""
    data = pq.read_table(sorted((root / "lerobot" / "data").rglob("*.parquet"))).to_pydict()
    meta = pq.read_table(sorted((root / "lerobot" / "meta" / "episodes").rglob("*.parquet")))
    keys = dict(
        zip(*meta.select(["episode_index", "datagen/key"]).to_pydict().values(), strict=True)
    )
    out = []
    for n in sorted(keys):
        rows = sorted(
            (f, i)
            for i, (e, f) in enumerate(zip(data["episode_index"], data["frame_index"], strict=True))
            if e == n
        )
        states = np.array([data["observation.state"][i] for _, i in rows])
        out.append((keys[n], states, np.array([data["action"][i] for _, i in rows])))
    return out


def _robomimic(root: Path) -> list[tuple[str, np.ndarray, np.ndarray]]:
    with h5py.File(root / "robomimic" / "demo.hdf5") as f:
        low, high = f["data"].attrs["action_min"], f["data"].attrs["action_max"]
        out = []
        for demo in f["data"].values():
            span = np.where(high > low, high - low, 0.0)
            action = low + (demo["actions"][:].astype(np.float64) + 1.0) / 2.0 * span
            out.append((demo.attrs["datagen_key"], demo["obs/pose"][:], action))
        return out


def _hdf5(root: Path, fps: float) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """One robot: the frames' poses and steps with ``trajectory/`` at the control rate; several:
    each robot's per-frame ``agents/<k>/pose`` and ``action``. Frames on the ``fps`` grid."""
    out = []
    with h5py.File(root / "episodes.h5") as f:
        for key, group in f["samples"].items():
            if "agents" in group:
                for k, agent in group["agents"].items():
                    times = group["r0/time_s"][:] if "r0" in group else group["time_s"][:]
                    grid = np.abs(times * fps - np.round(times * fps)) < 1e-6
                    actions = agent["action"][:].reshape(len(times), -1)
                    out.append((f"{key}.r{k}", agent["pose"][grid], actions[grid]))
                continue
            grid = np.abs(group["time_s"][:] * fps - np.round(group["time_s"][:] * fps)) < 1e-6
            commands, steps = group["trajectory/commands"][:], group["step"][grid]
            every = round(1.0 / (fps * group["trajectory"].attrs["dt"]))
            padded = np.vstack([commands, np.zeros((every, 2))])
            actions = np.stack([padded[s : s + every].ravel() for s in steps])
            out.append((key, group["pose"][grid], actions))
    return out


@pytest.mark.parametrize("name", sorted(BUILDS))
def test_exported_actions_reach_the_next_exported_pose(builds, name):
    root = builds[name]
    manifest = json.loads((root / "manifest.json").read_text())
    fps = float(manifest["config"]["navigation"]["frame_rate_hz"])
    robot = datagen.load(root)[0]["meta"]["robot"]
    readers = {"lerobot": _lerobot(root), "robomimic": _robomimic(root), "hdf5": _hdf5(root, fps)}
    for export, episodes in readers.items():
        assert len(episodes) == BUILDS[name][1] * BUILDS[name][0].get("robots", 1), export
        for key, states, actions in episodes:
            assert actions.shape == (len(states), 10), (export, key)  # 5 steps of 0.1 s per frame
            error = misses(states, actions, fps, robot)
            assert (error[:, 0] <= POSITION_M).all(), (export, key, error.max(axis=0))
            assert (error[:, 1] <= YAW_DEG).all(), (export, key, error.max(axis=0))
    # the command of the frame's step alone, held until the next frame, misses it (the old action)
    held = [misses(s, np.tile(a[:, :2], 5), fps, robot) for _, s, a in readers["lerobot"]]
    assert np.vstack(held)[:, 0].max() > 5 * POSITION_M


@pytest.mark.parametrize(
    ("trajectory", "named"),
    [
        ({"dt": 0.3}, "episode.trajectory.dt: frames at 2 Hz fall every 1.66667 control steps"),
        ({"dt": 0}, "episode.trajectory.dt: frames at 2 Hz fall every nan control steps"),
        ({"commands": [[0.1], [0.2, 0.3]]}, "episode.trajectory.commands: expected (steps, 2)"),
    ],
)
def test_a_trajectory_whose_actions_cannot_be_taken_is_refused_in_one_line(
    tmp_path_factory, tmp_path, trajectory, named
):
    def change(meta):
        meta["episode"]["trajectory"] |= trajectory

    root = forged(navigation_source(tmp_path_factory), tmp_path / "ds", meta=change)
    refused(cli("export", root, "--to", "lerobot"), str(root), "sample 000000000", named)
    assert not (root / "lerobot").exists()
