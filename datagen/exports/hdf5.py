"""HDF5 sequences: ``DIR/episodes.h5``, one group per sample, for sequence-learning code.

Layout (see docs/hdf5-layout.md): root attributes ``format``, ``scene``, ``classes`` (JSON),
``config`` (JSON); ``/index`` with per-sample ``keys`` (and ``success``, ``frames`` where they
exist); ``/samples/<key>`` per sample with its metadata JSON in the ``meta`` attribute.

What a group holds follows the sample's stored data, never its scene family's name. A sample
whose labelled views form a time sequence (``datagen.dataset.views``; navigation episodes)
stacks them along the first axis (``rgb`` T x H x W x 3, ``depth``, ``seg``, ``semantic``,
``depth_sensor`` and ``rgb_clean`` where the build made them, and
the per-frame records' ``pose``, ``command``, ...); a sample of cameras (grasp samples and
attempts) holds one image set per camera (``rgb``, ..., ``view1/rgb`` for the extra views of
``render.views``, ``wrist/rgb``, ``post/rgb``, ...).
An ``episode`` in the metadata adds ``trajectory/`` at the control rate, ``map``, ``occupancy``
and the outcome attributes; an ``attempt`` adds ``grasp/`` and its outcome.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from datagen.dataset.loader import decode_parts
from datagen.dataset.trajectory import decode_trajectory
from datagen.dataset.views import LabelledView, is_sequence, labelled_views, sequences
from datagen.exports.checks import checked_metadata
from datagen.exports.files import FailureRecordingFile
from datagen.outcomes import grasp_outcome, sample_outcome
from datagen.records import ExportedDataset, Manifest, SampleProgress

FORMAT = "datagen.hdf5/1"
_IMAGES = (
    "rgb",
    "depth",
    "seg",
    "semantic",
    "depth_sensor",
    "rgb_clean",
)  # the last two: where made
_IMAGE_PARTS = tuple(f"{n}.png" for n in _IMAGES)
_FRAME_FIELDS = {  # per-frame record field -> dtype, stacked when every frame has it
    "pose": np.float64, "command": np.float64, "goal_in_robot": np.float64,
    "distance_to_goal": np.float64, "collision": np.bool_, "time_s": np.float64,
    "step": np.int64, "extrinsics_world_to_camera": np.float64,
}  # fmt: skip
# whole-episode parts beside its frames
_EPISODE_PICTURES = ("map.png", "side.png", "occupancy.png", "occupancy.npz")
_FILM = re.compile(
    r"^frame\d+$"
)  # a recorded attempt's frames: frame3.rgb.png, frame3.wrist.rgb.png


def _images(group: h5py.Group, arrays: dict[str, np.ndarray], stacked: bool) -> None:
    for name in _IMAGES:
        if name in arrays:
            data = arrays[name]
            chunks = (1, *data.shape[1:]) if stacked else data.shape
            group.create_dataset(name, data=data, chunks=chunks, compression="gzip", compression_opts=1)  # fmt: skip


def _view_images(raw: dict[str, bytes], prefix: str) -> dict[str, Any]:
    return decode_parts({p: raw[prefix + p] for p in _IMAGE_PARTS if prefix + p in raw})


def _sequence(group: h5py.Group, raw: dict[str, bytes], views: list[LabelledView]) -> None:
    """The views stacked along a time axis, and the per-frame fields of their records."""
    decoded = [_view_images(raw, view.prefix) for view in views]
    stacks = {n: np.stack([d[n] for d in decoded]) for n in _IMAGES if all(n in d for d in decoded)}  # fmt: skip
    _images(group, stacks, stacked=True)
    records: list[Mapping[str, Any]] = [view.record for view in views]  # a field by its name
    for name, dtype in _FRAME_FIELDS.items():
        if all(name in record for record in records):
            group.create_dataset(name, data=np.array([r[name] for r in records], dtype=dtype))


def _agents(group: h5py.Group, records: list[Mapping[str, Any]]) -> None:
    """An episode's per-frame agent states (drones, or ground robots), stacked per agent:
    ``agents/<k>/<field>``, a nested record's fields as ``<field>_<name>`` (``imu_gyroscope``)."""
    for k in range(len(records[0]["agents"])):
        states = [r["agents"][k] for r in records]
        for name, value in states[0].items():
            if isinstance(value, dict):
                for sub in value:
                    data = np.array([s[name][sub] for s in states])
                    group.create_dataset(f"agents/{k}/{name}_{sub}", data=data)
            else:
                group.create_dataset(f"agents/{k}/{name}", data=np.array([s[name] for s in states]))


def _cameras(group: h5py.Group, raw: dict[str, bytes]) -> None:
    """One image set per camera: the unprefixed parts at the top, ``wrist.rgb.png`` -> wrist/rgb."""
    _images(group, _view_images(raw, ""), stacked=False)
    for name, value in raw.items():
        prefix, _, part = name.partition(".")
        if part in _IMAGE_PARTS and not _FILM.match(prefix):  # the film: _trajectory
            _images(group.require_group(prefix), decode_parts({part: value}), stacked=False)


def _episode(group: h5py.Group, episode: dict[str, Any], raw: dict[str, bytes]) -> None:
    if "trajectory" in episode:  # a ground episode's control-rate trajectory
        traj = group.create_group("trajectory")
        for name, values in episode["trajectory"].items():
            if isinstance(values, list):
                traj.create_dataset(name, data=np.asarray(values))
            else:
                traj.attrs[name] = values
    wanted = [
        p for p in raw if p in _EPISODE_PICTURES or (p.startswith("poses.") and p.endswith(".txt"))
    ]
    pictures = decode_parts({p: raw[p] for p in wanted})
    for name in ("map", "side"):
        if name in pictures:
            group.create_dataset(name, data=pictures[name], compression="gzip", compression_opts=1)
    if "occupancy" in pictures:  # a 2-D grid, or an aerial episode's voxels (nz, ny, nx)
        data = group.create_dataset("occupancy", data=pictures["occupancy"], compression="gzip")
        if "occupancy_resolution" in pictures:
            data.attrs["resolution_m"] = pictures["occupancy_resolution"]
    for camera, poses in pictures.get("poses", {}).items():
        group.create_dataset(f"poses/{camera}", data=poses)  # tx ty tz qx qy qz qw
    for name in ("path_length_m", "shortest_path_m", "spl"):
        group.attrs[name] = episode[name]


def _trajectory(group: h5py.Group, raw: dict[str, bytes]) -> None:
    """A recorded attempt (``trajectory.npz``): its arrays under ``trajectory/``, the column and
    phase names as JSON attribute ``names``, and the film stacked as ``frames/rgb`` (and
    ``frames/wrist_rgb``), one image per ``frame_time``."""
    arrays = decode_trajectory(raw["trajectory.npz"])
    traj = group.create_group("trajectory")
    traj.attrs["names"] = json.dumps(arrays.pop("names"), separators=(",", ":"), allow_nan=False)
    for name, values in arrays.items():
        traj.create_dataset(name, data=values, compression="gzip", compression_opts=1)
    for field, infix in (("rgb", ""), ("wrist_rgb", "wrist.")):
        names = [f"frame{k}.{infix}rgb.png" for k in range(len(arrays["frame_time"]))]
        if names and all(name in raw for name in names):
            stack = np.stack([decode_parts({"rgb.png": raw[name]})["rgb"] for name in names])
            traj.create_dataset(f"frames/{field}", data=stack, chunks=(1, *stack.shape[1:]), compression="gzip", compression_opts=1)  # fmt: skip


def _attempt(group: h5py.Group, attempt: dict[str, Any]) -> None:
    group.attrs["failure_mode"] = grasp_outcome(attempt)["failure_mode"] or ""
    if attempt["grasp"] is not None:
        grasp = group.create_group("grasp")
        grasp.create_dataset("pose_world", data=np.asarray(attempt["grasp"]["pose_world"]))
        grasp.attrs["width"] = attempt["grasp"]["width"]


def export(
    dataset: ExportedDataset,
    manifest: Manifest,
    out: Path,
    on_progress: SampleProgress | None = None,
) -> list[Path]:
    target = FailureRecordingFile(out)  # HDF5 never sees a failed write (it would crash)
    try:
        _write(target, dataset, manifest, on_progress)
    finally:
        target.close()
    if target.error is not None:
        raise OSError(target.error.errno, target.error.strerror, str(out))
    return [out]


def _write(target, dataset: ExportedDataset, manifest: Manifest, on_progress) -> None:
    keys, success, frames = [], [], []
    with h5py.File(target, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["scene"] = manifest.get("scene", "")
        f.attrs["classes"] = json.dumps(manifest.get("classes", []), allow_nan=False)
        f.attrs["config"] = json.dumps(manifest.get("config", {}), allow_nan=False)
        for i in range(len(dataset)):
            key, raw = dataset.keys[i], dataset.raw(i)
            meta = checked_metadata(decode_parts({"json": raw["json"]})["meta"])
            group = f.create_group(f"samples/{key}")
            group.attrs["meta"] = json.dumps(meta, separators=(",", ":"), allow_nan=False)
            views = labelled_views(meta)
            if is_sequence(views):
                by_camera = sequences(views)
                for camera, sequence in by_camera.items():
                    _sequence(group.require_group(camera) if camera else group, raw, sequence)
                frames.append(len(next(iter(by_camera.values()))))
                if any(isinstance(v.record.get("agents"), list) for v in views):
                    _agents(group, [v.record for v in next(iter(by_camera.values()))])
            else:
                _cameras(group, raw)
            if meta.get("episode"):
                _episode(group, meta["episode"], raw)
            if meta.get("attempt"):
                _attempt(group, meta["attempt"])
            if "trajectory.npz" in raw:
                _trajectory(group, raw)
            keys.append(key)
            if (outcome := sample_outcome(meta)) is not None:
                group.attrs["success"] = outcome["success"]
                success.append(outcome["success"])
            if on_progress:
                on_progress(i + 1, len(dataset))
        index = f.create_group("index")
        index.create_dataset("keys", data=np.array(keys, dtype="S"))
        if len(success) == len(keys):
            index.create_dataset("success", data=np.array(success, dtype=bool))
        if len(frames) == len(keys):
            index.create_dataset("frames", data=np.array(frames, dtype=np.int64))
