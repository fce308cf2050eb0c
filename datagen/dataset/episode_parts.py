"""The parts episodes share and how they are read: frames over time (``f0003.rgb.png``, one
camera; ``f0003.d0.rgb.png`` and ``.flow.png``, several), camera pose files, the map pictures
and occupancy grids; and the decoders of an aerial episode's voxel grid and IMU streams. The
formats that write them list these rules in their ``PARTS`` (``datagen.formats``)."""

from __future__ import annotations

import io
import re
import zipfile
from typing import Any

import numpy as np

from datagen.dataset.manifest import DatasetError
from datagen.dataset.part_rules import (
    CAMERA_NAME,
    IMAGE_KINDS,
    Decoding,
    PartRule,
    image_rule,
)

# one camera over time: f0003.rgb.png; several: f0003.d0.rgb.png, f0003.d1_down.flow.png
FRAME_PART = re.compile(rf"f(\d{{4}})\.({IMAGE_KINDS})\.png")
CAMERA_FRAME_PART = re.compile(rf"f(\d{{4}})\.({CAMERA_NAME})\.({IMAGE_KINDS}|flow)\.png")


def _camera_frame(decoding: Decoding, match: re.Match[str]) -> dict[str, Any]:
    return decoding.frame(int(match[1])).setdefault("cameras", {}).setdefault(match[2], {})


def _pose_file(decoding: Decoding, match: re.Match[str], data: bytes) -> None:
    decoding.item.setdefault(match[1], {})[match[2]] = pose_lines(data, match[0])


def _picture(decoding: Decoding, match: re.Match[str], data: bytes) -> None:
    decoding.image(decoding.item, match[1], "rgb.png", data)


def _occupancy_picture(decoding: Decoding, match: re.Match[str], data: bytes) -> None:
    decoding.image(decoding.item, "occupancy", "occupancy.png", data)


FRAME_IMAGES = image_rule(FRAME_PART.pattern, lambda d, m: d.frame(int(m[1])))
CAMERA_FRAMES = image_rule(CAMERA_FRAME_PART.pattern, _camera_frame)
POSE_FILES = PartRule(re.compile(rf"(poses|poses_ned)\.({CAMERA_NAME})\.txt"), _pose_file)
MAP_PICTURES = PartRule(re.compile(r"(map|side)\.png"), _picture)  # RGB
OCCUPANCY_PICTURE = PartRule(re.compile(r"occupancy\.png"), _occupancy_picture)  # True: occupied


def pose_lines(data: bytes, name: str) -> np.ndarray:
    """(T, 7) float64 from lines of ``tx ty tz qx qy qz qw``."""
    try:
        rows = [
            [float(v) for v in line.split()] for line in data.decode().splitlines() if line.strip()
        ]
        poses = np.asarray(rows, float).reshape(-1, 7)
    except (UnicodeDecodeError, ValueError):
        raise DatasetError(
            f"part {name!r}: expected lines of 7 numbers (tx ty tz qx qy qz qw)"
        ) from None
    return poses


def voxel_grid(data: bytes) -> tuple[np.ndarray, float]:
    """The voxel grid of ``occupancy.npz`` (packed bits, its shape and voxel side)."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            shape = tuple(int(v) for v in npz["shape"])
            packed = npz["occupancy"]
            if len(shape) != 3 or min(shape) < 1 or np.prod(shape) > 8 * packed.size:
                raise ValueError(f"shape {shape} does not fit {packed.size} bytes")
            bits = np.unpackbits(packed, count=int(np.prod(shape)))
            return bits.reshape(shape).astype(bool), float(npz["resolution"])
    except (OSError, KeyError, ValueError) as exc:
        raise DatasetError(f"part 'occupancy.npz': not a datagen voxel grid ({exc})") from None


IMU_READINGS = ("time_s", "accelerometer", "gyroscope")  # in every imu.d<k>.npz


def imu_stream(data: bytes, name: str) -> dict[str, np.ndarray]:
    """The arrays of a drone's ``imu.d<k>.npz`` (:mod:`datagen.families.aerial.imu`, docs/aerial.md)."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            arrays = {key: npz[key] for key in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise DatasetError(f"part {name!r}: not a datagen IMU stream ({exc})") from None
    missing = [key for key in IMU_READINGS if key not in arrays]
    if missing:
        raise DatasetError(f"part {name!r}: not a datagen IMU stream (no {', '.join(missing)})")
    return arrays


TRAJECTORY_ARRAYS = ("take_off_s", "piece_times_s", "position_coefficients", "yaw_coefficients")


def imu_for_frame(
    episodes: Any, i: int, meta: Any, camera: str, k: int
) -> dict[str, np.ndarray] | None:
    """The IMU samples of ``camera``'s drone in episode ``i`` (metadata ``meta``) since the
    previous frame: times in (t_(k-1), t_k], frame 0's up to t_0, each per-sample array of its
    ``imu.d<k>.npz`` sliced alike; None where the episode has no such part. ``episodes``: a
    :class:`datagen.dataset.loader.ShardDataset`."""
    records = meta["frames"]
    drone = meta["cameras"][camera]["drone"]
    name = f"imu.d{drone}.npz"
    if name not in episodes.part_names(i):
        return None
    arrays = imu_stream(episodes.raw(i, {name})[name], name)
    time = arrays["time_s"]
    end = float(records[k]["time_s"]) + 5e-7  # frame times are stored to 6 decimals
    start = float(records[k - 1]["time_s"]) + 5e-7 if k else -np.inf
    keep = (time > start) & (time <= end)
    return {key: a[keep] for key, a in arrays.items() if key not in TRAJECTORY_ARRAYS}
