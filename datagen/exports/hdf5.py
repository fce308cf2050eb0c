"""HDF5 sequences: ``DIR/episodes.h5``, one group per sample, for sequence-learning code.

Layout (see docs/hdf5-layout.md): root attributes ``format``, ``scene``, ``classes`` (JSON),
``config`` (JSON); ``/index`` with per-sample ``keys`` (and ``success``, ``frames`` where they
exist); ``/samples/<key>`` per sample with its metadata JSON in the ``meta`` attribute. Navigation
episodes stack their frames along the first axis (``rgb`` T x H x W x 3, ``depth``, ``seg``,
``semantic``, and per-frame ``pose``, ``command``, ...), and add ``trajectory/`` at the control
rate, ``map`` and ``occupancy``. Grasp samples and attempts hold one image set per camera
(``rgb``, ..., ``post/rgb``, ...) and attempts their ``grasp/`` and outcome.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from tqdm import tqdm

from datagen.dataset.loader import decode_parts

NAME = "hdf5"
FORMAT = "datagen.hdf5/1"
_IMAGES = ("rgb", "depth", "seg", "semantic")
_IMAGE_PARTS = {f"{n}.png" for n in _IMAGES}
_FRAME_FIELDS = {  # per-frame record field -> dtype
    "pose": np.float64, "command": np.float64, "goal_in_robot": np.float64,
    "distance_to_goal": np.float64, "collision": np.bool_, "time_s": np.float64,
    "step": np.int64, "extrinsics_world_to_camera": np.float64,
}  # fmt: skip


def _images(group: h5py.Group, arrays: dict[str, np.ndarray], stacked: bool) -> None:
    for name in _IMAGES:
        if name in arrays:
            data = arrays[name]
            chunks = (1, *data.shape[1:]) if stacked else data.shape
            group.create_dataset(name, data=data, chunks=chunks, compression="gzip", compression_opts=1)  # fmt: skip


def _episode(group: h5py.Group, item: dict[str, Any]) -> None:
    frames, meta = item["frames"], item["meta"]
    _images(group, {n: np.stack([f[n] for f in frames]) for n in _IMAGES}, stacked=True)
    for name, dtype in _FRAME_FIELDS.items():
        group.create_dataset(name, data=np.array([f["meta"][name] for f in frames], dtype=dtype))
    traj = group.create_group("trajectory")
    for name, values in meta["episode"]["trajectory"].items():
        if isinstance(values, list):
            traj.create_dataset(name, data=np.asarray(values))
        else:
            traj.attrs[name] = values
    group.create_dataset("map", data=item["map"], compression="gzip", compression_opts=1)
    group.create_dataset("occupancy", data=item["occupancy"], compression="gzip")
    for name in ("success", "path_length_m", "shortest_path_m", "spl"):
        group.attrs[name] = meta["episode"][name]


def _views(group: h5py.Group, item: dict[str, Any]) -> None:
    _images(group, item, stacked=False)
    for name, value in item.items():  # other cameras: "wrist.rgb.png" -> wrist/rgb
        prefix, _, part = name.partition(".")
        if isinstance(value, bytes) and part in _IMAGE_PARTS:
            decoded = decode_parts({part: value})
            _images(group.require_group(prefix), decoded, stacked=False)
    attempt = item["meta"].get("attempt")
    if attempt:
        group.attrs["success"] = attempt["outcome"]["success"]
        group.attrs["failure_mode"] = attempt["outcome"]["failure_mode"] or ""
        if attempt["grasp"] is not None:
            grasp = group.create_group("grasp")
            grasp.create_dataset("pose_world", data=np.asarray(attempt["grasp"]["pose_world"]))
            grasp.attrs["width"] = attempt["grasp"]["width"]


def export(dataset, manifest: dict[str, Any], out: Path) -> list[Path]:
    keys, success, frames = [], [], []
    with h5py.File(out, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["scene"] = manifest.get("scene", "")
        f.attrs["classes"] = json.dumps(manifest.get("classes", []))
        f.attrs["config"] = json.dumps(manifest.get("config", {}))
        for i in tqdm(range(len(dataset)), desc="hdf5", unit="sample", leave=False):
            item = dataset[i]
            group = f.create_group(f"samples/{item['key']}")
            group.attrs["meta"] = json.dumps(item["meta"], separators=(",", ":"))
            if "frames" in item:
                _episode(group, item)
                frames.append(len(item["frames"]))
            else:
                _views(group, item)
            keys.append(item["key"])
            if "success" in group.attrs:
                success.append(bool(group.attrs["success"]))
        index = f.create_group("index")
        index.create_dataset("keys", data=np.array(keys, dtype="S"))
        if len(success) == len(keys):
            index.create_dataset("success", data=np.array(success, dtype=bool))
        if len(frames) == len(keys):
            index.create_dataset("frames", data=np.array(frames, dtype=np.int64))
    return [out]
