"""Decoding the episode-level parts of an aerial sample: camera pose files and the voxel grid
(the images go through :func:`datagen.dataset.loader.decode_parts`)."""

from __future__ import annotations

import io

import numpy as np

from datagen.dataset.manifest import DatasetError


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
