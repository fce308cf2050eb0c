"""robomimic's HDF5 dataset: ``DIR/robomimic/demo.hdf5``, one ``data/demo_<k>`` per episode
(``datagen.exports.episodes``), read by robomimic's ``SequenceDataset`` as it is.

Layout and every mapping decision: docs/export-robomimic.md. In short: ``obs`` and ``next_obs``
(obs shifted by one frame, the last repeated) under robomimic's key names, ``actions`` scaled to
[-1, 1] per dimension over the whole dataset (the scale in ``data`` attributes ``action_min`` /
``action_max``), ``rewards``, ``dones``, ``states`` (the flat simulator state), the labelled views
of the sample under ``perception/``, and ``mask/train`` / ``mask/valid`` by
``datagen.exports.splits``. Written in two passes: the first reads the trajectories only (no
images) for the action range, the second writes one episode's images at a time.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, cast

import h5py
import numpy as np

from datagen.dataset.parts import decode_parts
from datagen.dataset.views import labelled_views
from datagen.exports.checks import positive_metres, sample_metadata
from datagen.exports.episodes import Episode, episodes, episodes_of, frames_of
from datagen.exports.files import FailureRecordingFile
from datagen.exports.left_out import LeftOut
from datagen.exports.splits import is_valid
from datagen.records import ExportedDataset, Manifest, SampleProgress

# robomimic's EnvType.GYM_TYPE (robosuite 1, gym 2, iGibson MOMART 3): no robomimic type is a
# datagen scene, and robosuite's would have robomimic's playback scripts reset a robosuite MuJoCo
# simulator from ``states``, which datagen's are not (docs/export-robomimic.md; rollouts off)
ENV_TYPE = 2
IMAGE_KEYS = {"workspace": "agentview_image", "wrist": "robot0_eye_in_hand_image"}
_PERCEPTION = ("rgb", "depth", "seg", "semantic")


def export(
    dataset: ExportedDataset,
    manifest: Manifest,
    out: Path,
    on_progress: SampleProgress | None = None,
) -> list[Path]:
    """Writes ``out/demo.hdf5`` (``out``: a fresh folder); returns the files written."""
    out.mkdir(parents=True)
    path = out / "demo.hdf5"
    low, high, first = _action_range(dataset, manifest)
    target = FailureRecordingFile(path)  # HDF5 never sees a failed write (it would crash)
    try:
        with h5py.File(target, "w") as f:
            _write(f, dataset, manifest, (low, high), first, on_progress)
    finally:
        target.close()
    if target.error is not None:
        raise OSError(target.error.errno, target.error.strerror, str(path))
    return [path]


def _action_range(dataset: ExportedDataset, manifest: Manifest):
    """First pass: per-dimension (min, max) of every episode's actions, float64, and the position
    of the first sample holding an episode (None if none does)."""
    low = high = None
    first = None
    for i, episode in episodes(dataset, manifest):
        action = episode.action.astype(np.float64)
        low = action.min(0) if low is None else np.minimum(low, action.min(0))
        high = action.max(0) if high is None else np.maximum(high, action.max(0))
        first = i if first is None else first
    if low is None:
        return np.zeros(0), np.zeros(0), None
    return low, high, first


def normalise(action: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """(T, A) -> [-1, 1] per dimension; a dimension that never changes maps to 0."""
    span = high - low
    scaled = 2.0 * (action.astype(np.float64) - low) / np.where(span > 0, span, 1.0) - 1.0
    return np.where(span > 0, scaled, 0.0).astype(np.float32)


def _env_args(dataset: ExportedDataset, manifest: Manifest, first: int | None) -> dict[str, Any]:
    meta = cast(dict[str, Any], dataset.metadata(first)) if first is not None else {}
    robot = meta.get("robot", {})
    scene = manifest.get("scene", "")
    version = cast(dict[str, str], manifest.get("versions", {})).get("datagen", "")
    return {  # robomimic reads env_name, type and env_kwargs (EnvUtils.get_env_type: "type")
        "env_name": f"datagen/{scene}",
        "type": ENV_TYPE,
        "env_version": version,
        "env_kwargs": {
            "scene": scene,
            "robot": {"name": robot.get("name", ""), "description": robot.get("description", "")},
            "seed": manifest.get("seed"),
            "datagen_version": version,
            "build_id": manifest.get("build_id", ""),
            "config": manifest.get("config", {}),
        },
    }


def _write(f: h5py.File, dataset, manifest, scale, first, on_progress) -> None:
    data = f.create_group("data")
    low, high = scale
    names: dict[str, list[str]] = {"train": [], "valid": []}
    total, left = 0, LeftOut()
    for i in range(len(dataset)):
        written = {"json", "trajectory.npz"}  # the metadata and trajectory the demos come from
        held = episodes_of(dataset, manifest, i)
        for episode in held:
            name = f"demo_{len(names['train']) + len(names['valid'])}"
            written |= _demo(data.create_group(name), dataset, i, episode, scale)
            names["valid" if is_valid(episode.key) else "train"].append(name)
            total += episode.length
            if "action_names" not in data.attrs:
                data.attrs["action_names"] = json.dumps(episode.action_names, allow_nan=False)
        if held:  # a sample holding none is left out whole (docs/exports.md)
            left.add(dataset.part_names(i), written)
        if on_progress:
            on_progress(i + 1, len(dataset))
    data.attrs["total"] = total
    data.attrs["left_out"] = json.dumps(left.kinds())
    data.attrs["env_args"] = json.dumps(_env_args(dataset, manifest, first), allow_nan=False)
    data.attrs["action_min"] = low
    data.attrs["action_max"] = high
    data.attrs["classes"] = json.dumps(manifest.get("classes", []), allow_nan=False)
    for split, demos in names.items():
        f.create_dataset(f"mask/{split}", data=np.array(demos, dtype="S"))


def _quat_xyzw(wxyz: np.ndarray) -> np.ndarray:
    return wxyz[:, [1, 2, 3, 0]]


def _low_dim(episode: Episode) -> tuple[dict[str, np.ndarray], np.ndarray, list[str]]:
    """(observation name -> (T, k) float32, states (T, D) float64, state column names)."""
    if episode.kind == "navigation":
        pose = episode.state
        obs = {"pose": pose, "goal_in_robot": episode.extras["goal_in_robot"]}
        return obs, pose.astype(np.float64), list(episode.state_names)
    if episode.kind == "aerial":
        state = episode.state  # position, quaternion x y z w, velocity
        obs = {
            "position": state[:, :3],
            "quaternion_xyzw": state[:, 3:7],
            "velocity": state[:, 7:],
            "goal_in_body": episode.extras["goal_in_body"],
            "imu": episode.extras["imu"],
        }
        return obs, state.astype(np.float64), list(episode.state_names)
    state, qvel = episode.state, episode.extras["qvel"]
    arm = [k for k, n in enumerate(episode.state_names) if n in episode.action_names]
    fingers = [k for k in range(state.shape[1]) if k not in arm]
    tcp, target = episode.extras["tcp_pose"], episode.extras["target_pose"]
    obs = {
        "robot0_joint_pos": state[:, arm],
        "robot0_joint_vel": qvel[:, arm],
        "robot0_gripper_qpos": state[:, fingers],
        "robot0_gripper_qvel": qvel[:, fingers],
        "robot0_eef_pos": tcp[:, :3],
        "robot0_eef_quat": _quat_xyzw(tcp[:, 3:]),
        "object": np.concatenate(
            [target[:, :3], _quat_xyzw(target[:, 3:]), target[:, :3] - tcp[:, :3]], axis=1
        ),
    }
    obs = {k: v.astype(np.float32) for k, v in obs.items()}
    states = np.concatenate([state, qvel, target], axis=1).astype(np.float64)
    joints = list(episode.state_names)
    axes = ["x", "y", "z", "qw", "qx", "qy", "qz"]
    return obs, states, [*joints, *(f"{j}.vel" for j in joints), *(f"target.{p}" for p in axes)]


def _put(group: h5py.Group, name: str, values: np.ndarray) -> None:
    if values.ndim >= 3:  # images: one frame per chunk
        group.create_dataset(
            name, data=values, chunks=(1, *values.shape[1:]), compression="gzip", compression_opts=1
        )
    else:
        group.create_dataset(name, data=values)


def _images(episode: Episode, raw: dict[str, bytes], far_m: float) -> dict[str, np.ndarray]:
    """Colour (T, H, W, 3) uint8 and depth (T, H, W, 1) float32 in [0, 1] (metres / far_m)."""
    obs = {}
    for camera, parts in episode.cameras.items():
        obs[IMAGE_KEYS.get(camera, f"{camera}_image")] = frames_of(raw, parts)
    for camera, parts in episode.depth.items():
        metres = frames_of(raw, parts).astype(np.float32) / np.float32(1000.0)
        obs[f"{camera}_depth"] = (metres / np.float32(far_m))[..., None]
    return obs


def _demo(group: h5py.Group, dataset, i: int, episode: Episode, scale) -> set[str]:
    """One demo; returns the sample's parts it holds."""
    meta = sample_metadata(dataset, i)
    views = labelled_views(meta)
    wanted = episode.parts() | {f"{v.prefix}{n}.png" for v in views for n in _PERCEPTION}
    raw = dataset.raw(i, wanted & set(dataset.part_names(i)))
    far_m = 0.0
    if episode.depth:  # depth is stored as a fraction of the camera's far plane
        far_m = positive_metres(views[0].camera.get("far") if views else None, "its camera's far")
    obs, states, state_names = _low_dim(episode)
    for name, values in (obs | _images(episode, raw, far_m)).items():
        _put(group, f"obs/{name}", values)
        _put(group, f"next_obs/{name}", np.concatenate([values[1:], values[-1:]]))
    group.create_dataset("actions", data=normalise(episode.action, *scale))
    group.create_dataset("rewards", data=episode.reward.astype(np.float64))
    group.create_dataset("dones", data=episode.done.astype(np.int64))
    group.create_dataset("states", data=states)
    group.attrs["num_samples"] = episode.length
    group.attrs["datagen_key"] = episode.key
    group.attrs["success"] = episode.success
    group.attrs["fps"] = episode.fps
    group.attrs["state_names"] = json.dumps(state_names, allow_nan=False)
    group.attrs["ep_meta"] = json.dumps({"lang": episode.task}, allow_nan=False)
    if episode.depth:
        group.attrs["depth_far_m"] = far_m
    return episode.parts() | _perception(group.create_group("perception"), episode, views, raw)


def _perception(group: h5py.Group, episode: Episode, views, raw: dict[str, bytes]) -> set[str]:
    """Grasp attempts: each labelled camera view of the sample (before the grasp) under its
    camera's name; navigation: the frames' seg and semantic stacked like the episode's frames.
    Returns the parts written."""
    if episode.kind in ("navigation", "aerial"):  # a sequence: its first camera's frames
        by_prefix = {v.prefix: v for v in views}
        frames = next(iter(episode.cameras.values()))  # the one camera's PNG part per frame
        kept = [by_prefix[p.removesuffix("rgb.png")] for p in frames]
        for kind in ("seg", "semantic"):
            stack = np.stack([_decode(raw, v.prefix, kind) for v in kept])
            _put(group, kind, stack)
        group.attrs["instances"] = json.dumps(
            [v.instances for v in kept], separators=(",", ":"), allow_nan=False
        )
        return {f"{v.prefix}{kind}.png" for v in kept for kind in ("seg", "semantic")}
    written = set()
    for view in views:
        sub = group.create_group(view.name or "workspace")
        for kind in _PERCEPTION:
            if f"{view.prefix}{kind}.png" in raw:
                image = _decode(raw, view.prefix, kind)
                sub.create_dataset(kind, data=image, compression="gzip", compression_opts=1)
                written.add(f"{view.prefix}{kind}.png")
        sub.attrs["instances"] = json.dumps(view.instances, separators=(",", ":"), allow_nan=False)
        sub.attrs["camera"] = json.dumps(view.camera, separators=(",", ":"), allow_nan=False)
    return written


def _decode(raw: dict[str, bytes], prefix: str, kind: str) -> np.ndarray:
    return decode_parts({f"{kind}.png": raw[f"{prefix}{kind}.png"]})[kind]
