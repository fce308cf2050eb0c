"""HDF5 sequences: ``DIR/episodes.h5``, one group per sample, for sequence-learning code.

Layout (see docs/hdf5-layout.md): root attributes ``format``, ``scene``, ``classes`` (JSON),
``config`` (JSON); ``/index`` with per-sample ``keys`` (and ``success``, ``frames`` where they
exist); ``/samples/<key>`` per sample with its metadata JSON in the ``meta`` attribute.

What a group holds follows the sample's stored data, never its scene family's name. A sample
whose labelled views form a time sequence (``datagen.dataset.views``; navigation episodes)
stacks them along the first axis (``rgb`` T x H x W x 3, ``depth``, ``seg``, ``semantic``,
``depth_sensor`` and ``rgb_clean`` where the build made them, ``flow`` and ``flow_valid`` for the
T - 1 frames that have a next one (aerial), the camera's ``extrinsics_world_to_camera`` and
the per-frame records' ``pose``, ``command``, ...); a sample of cameras (grasp samples and
attempts) holds one image set per camera (``rgb``, ..., ``view1/rgb`` for the extra views of
``render.views``, ``wrist/rgb``, ``post/rgb``, ...).
An ``episode`` in the metadata adds ``trajectory/`` at the control rate, ``map``, ``occupancy``,
the camera pose files, the drones' IMU streams and the outcome attributes; an ``attempt`` adds
``grasp/`` and its outcome. Every group's ``left_out`` attribute (JSON) lists the kinds of the
sample's parts that nothing in the file holds (``[]``: none), the root's those of any sample.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from datagen.dataset.flow_png import decode_flow_image
from datagen.dataset.parts import decode_parts
from datagen.dataset.trajectory import decode_trajectory
from datagen.dataset.views import LabelledView, is_sequence, labelled_views, sequences
from datagen.exports.checks import checked_metadata
from datagen.exports.files import FailureRecordingFile
from datagen.exports.left_out import LeftOut
from datagen.images import decode_image
from datagen.outcomes import grasp_outcome, sample_outcome
from datagen.records import ExportedDataset, Manifest, SampleMetadata, SampleProgress

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
    "pose": np.float64,
    "command": np.float64,
    "goal_in_robot": np.float64,
    "distance_to_goal": np.float64,
    "collision": np.bool_,
    "time_s": np.float64,
    "step": np.int64,
    "extrinsics_world_to_camera": np.float64,
}
# whole-episode parts beside its frames
_EPISODE_PICTURES = ("map.png", "side.png", "occupancy.png", "occupancy.npz")
_EPISODE_FILES = re.compile(r"^(poses|poses_ned)\.[A-Za-z][\w-]*\.txt$|^imu\.d\d+\.npz$")
_FILM = re.compile(
    r"^frame\d+$"
)  # a recorded attempt's frames: frame3.rgb.png, frame3.wrist.rgb.png


def _images(group: h5py.Group, arrays: dict[str, np.ndarray], stacked: bool) -> None:
    for name in _IMAGES:
        if name in arrays:
            data = arrays[name]
            chunks = (1, *data.shape[1:]) if stacked else data.shape
            group.create_dataset(
                name, data=data, chunks=chunks, compression="gzip", compression_opts=1
            )


def _view_images(raw: dict[str, bytes], prefix: str) -> dict[str, Any]:
    return decode_parts({p: raw[prefix + p] for p in _IMAGE_PARTS if prefix + p in raw})


def _sequence(group: h5py.Group, raw: dict[str, bytes], views: list[LabelledView]) -> set[str]:
    """The views stacked along a time axis, their optical flow, and the per-frame fields of
    their records and cameras; returns the parts written."""
    decoded = [_view_images(raw, view.prefix) for view in views]
    stacks = {n: np.stack([d[n] for d in decoded]) for n in _IMAGES if all(n in d for d in decoded)}
    _images(group, stacks, stacked=True)
    records: list[Mapping[str, Any]] = [  # a field by its name; extrinsics: the view's camera's
        {**view.record, "extrinsics_world_to_camera": view.camera.get("extrinsics_world_to_camera")}
        for view in views
    ]
    for name, dtype in _FRAME_FIELDS.items():
        if all(record.get(name) is not None for record in records):
            group.create_dataset(name, data=np.array([r[name] for r in records], dtype=dtype))
    written = {v.prefix + f"{n}.png" for v in views for n in stacks}
    return written | _flow(group, raw, views)


def _flow(group: h5py.Group, raw: dict[str, bytes], views: list[LabelledView]) -> set[str]:
    """``flow`` (F, H, W, 2) float32 pixels from frame t to t + 1 and ``flow_valid`` (F, H, W),
    for the first F frames that have a flow part (all but the last); returns the parts written."""
    names = [f"{view.prefix}flow.png" for view in views]
    have = [name for name in names if name in raw]
    if not have or have != names[: len(have)]:
        return set()
    flows = [decode_flow_image(decode_image(raw[name], what=f"part {name!r}")) for name in have]
    _stacked(group, "flow", np.stack([flow for flow, _ in flows]))
    _stacked(group, "flow_valid", np.stack([valid for _, valid in flows]))
    return set(have)


def _stacked(group: h5py.Group, name: str, data: np.ndarray) -> None:
    """A stack of frames, one frame per chunk, gzip level 1."""
    chunks = (1, *data.shape[1:])
    group.create_dataset(name, data=data, chunks=chunks, compression="gzip", compression_opts=1)


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


def _cameras(group: h5py.Group, raw: dict[str, bytes]) -> set[str]:
    """One image set per camera: the unprefixed parts at the top, ``wrist.rgb.png`` -> wrist/rgb;
    returns the parts written."""
    _images(group, _view_images(raw, ""), stacked=False)
    written = {p for p in _IMAGE_PARTS if p in raw}
    for name, value in raw.items():
        prefix, _, part = name.partition(".")
        if part in _IMAGE_PARTS and not _FILM.match(prefix):  # the film: _trajectory
            _images(group.require_group(prefix), decode_parts({part: value}), stacked=False)
            written.add(name)
    return written


def _episode(group: h5py.Group, episode: dict[str, Any], raw: dict[str, bytes]) -> set[str]:
    """The episode record's trajectory and outcome, and its whole-episode parts: pictures,
    occupancy, camera pose files and IMU streams; returns the parts written."""
    if "trajectory" in episode:  # a ground episode's control-rate trajectory
        traj = group.create_group("trajectory")
        for name, values in episode["trajectory"].items():
            if isinstance(values, list):
                traj.create_dataset(name, data=np.asarray(values))
            else:
                traj.attrs[name] = values
    wanted = [p for p in raw if p in _EPISODE_PICTURES or _EPISODE_FILES.match(p)]
    pictures = decode_parts({p: raw[p] for p in wanted})
    written = set()
    for name in ("map", "side"):
        if name in pictures:
            group.create_dataset(name, data=pictures[name], compression="gzip", compression_opts=1)
            written.add(f"{name}.png")
    if "occupancy" in pictures:  # a 2-D grid, or an aerial episode's voxels (nz, ny, nx)
        data = group.create_dataset("occupancy", data=pictures["occupancy"], compression="gzip")
        written |= {"occupancy.png", "occupancy.npz"} & set(raw)
        if "occupancy_resolution" in pictures:
            data.attrs["resolution_m"] = pictures["occupancy_resolution"]
    for field in ("poses", "poses_ned"):  # camera -> (T, 7) tx ty tz qx qy qz qw
        for camera, poses in pictures.get(field, {}).items():
            group.create_dataset(f"{field}/{camera}", data=poses)
            written.add(f"{field}.{camera}.txt")
    for drone, arrays in pictures.get("imu", {}).items():
        for name, values in arrays.items():
            group.create_dataset(f"imu/{drone}/{name}", data=values)
        written.add(f"imu.{drone}.npz")
    for name in ("path_length_m", "shortest_path_m", "spl"):
        group.attrs[name] = episode[name]
    return written


def _trajectory(group: h5py.Group, raw: dict[str, bytes]) -> set[str]:
    """A recorded attempt (``trajectory.npz``): its arrays under ``trajectory/``, the column and
    phase names as JSON attribute ``names``, and the film stacked as ``frames/rgb`` (and
    ``frames/wrist_rgb``), one image per ``frame_time``; returns the parts written."""
    arrays = decode_trajectory(raw["trajectory.npz"])
    traj = group.create_group("trajectory")
    traj.attrs["names"] = json.dumps(arrays.pop("names"), separators=(",", ":"), allow_nan=False)
    for name, values in arrays.items():
        traj.create_dataset(name, data=values, compression="gzip", compression_opts=1)
    written = {"trajectory.npz"}
    for field, infix in (("rgb", ""), ("wrist_rgb", "wrist.")):
        names = [f"frame{k}.{infix}rgb.png" for k in range(len(arrays["frame_time"]))]
        if names and all(name in raw for name in names):
            stack = np.stack([decode_parts({"rgb.png": raw[name]})["rgb"] for name in names])
            _stacked(traj, f"frames/{field}", stack)
            written |= set(names)
    return written


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


def _sample(
    group: h5py.Group, meta: SampleMetadata, raw: dict[str, bytes], left: LeftOut
) -> int | None:
    """One sample's group; returns its number of frames if it is a sequence. Its ``left_out``
    attribute lists the kinds of its parts of which it holds none (``left`` gathers them)."""
    group.attrs["meta"] = json.dumps(meta, separators=(",", ":"), allow_nan=False)
    views, frames, written = labelled_views(meta), None, {"json"}
    if is_sequence(views):
        by_camera = sequences(views)
        for camera, sequence in by_camera.items():
            written |= _sequence(group.require_group(camera) if camera else group, raw, sequence)
        frames = len(next(iter(by_camera.values())))
        if any(isinstance(v.record.get("agents"), list) for v in views):
            _agents(group, [v.record for v in next(iter(by_camera.values()))])
    else:
        written |= _cameras(group, raw)
    if meta.get("episode"):
        written |= _episode(group, meta["episode"], raw)
    if meta.get("attempt"):
        _attempt(group, meta["attempt"])
    if "trajectory.npz" in raw:
        written |= _trajectory(group, raw)
    if (outcome := sample_outcome(meta)) is not None:
        group.attrs["success"] = outcome["success"]
    own = LeftOut()
    own.add(raw, written)
    left.add(raw, written)
    group.attrs["left_out"] = json.dumps(own.kinds())
    return frames


def _write(target, dataset: ExportedDataset, manifest: Manifest, on_progress) -> None:
    keys, success, frames, left = [], [], [], LeftOut()
    with h5py.File(target, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["scene"] = manifest.get("scene", "")
        f.attrs["classes"] = json.dumps(manifest.get("classes", []), allow_nan=False)
        f.attrs["config"] = json.dumps(manifest.get("config", {}), allow_nan=False)
        for i in range(len(dataset)):
            key, raw = dataset.keys[i], dataset.raw(i)
            meta = checked_metadata(decode_parts({"json": raw["json"]})["meta"])
            group = f.create_group(f"samples/{key}")
            count = _sample(group, meta, raw, left)
            frames += [] if count is None else [count]
            success += [group.attrs["success"]] if "success" in group.attrs else []
            keys.append(key)
            if on_progress:
                on_progress(i + 1, len(dataset))
        f.attrs["left_out"] = json.dumps(left.kinds())
        index = f.create_group("index")
        index.create_dataset("keys", data=np.array(keys, dtype="S"))
        if len(success) == len(keys):
            index.create_dataset("success", data=np.array(success, dtype=bool))
        if len(frames) == len(keys):
            index.create_dataset("frames", data=np.array(frames, dtype=np.int64))
