"""Encoding rendered views into a sample's named parts: PNG images, compact sorted JSON.

PNG level (``output.png_level``, measured in docs/performance.md): 1, the default, is OpenCV's
speed preset (SUB filter, zlib level 1, run-length strategy), the fastest setting measured and
the bytes datagen has always written; 2-9 are zlib levels with libpng's adaptive filters
(smaller, slower); 0 stores the pixels uncompressed. Every level decodes to the same pixels.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from datagen.records import SampleMetadata
from datagen.sensing.stage_clock import timed

DEFAULT_PNG_LEVEL = 1
PNG_LEVELS = range(0, 10)
_ENCODE_THREADS = min(4, os.cpu_count() or 1)  # one per image of a view; cv2 releases the GIL


@dataclass
class View:
    rgb: np.ndarray  # (H, W, 3) uint8, RGB
    depth: np.ndarray  # (H, W) uint16 millimetres
    instance: np.ndarray  # (H, W) uint16
    semantic: np.ndarray  # (H, W) uint8
    depth_sensor: np.ndarray | None = None  # (H, W) uint16 millimetres, 0 = no reading
    rgb_clean: np.ndarray | None = None  # (H, W, 3) uint8 RGB before the camera effects


def png_params(level: int) -> list[int]:
    if level not in PNG_LEVELS:
        raise ValueError(f"PNG level must be 0-9, got {level!r}")
    return [] if level == DEFAULT_PNG_LEVEL else [cv2.IMWRITE_PNG_COMPRESSION, level]


def _png(image: np.ndarray, level: int, bgr_from_rgb: bool = False) -> bytes:
    if bgr_from_rgb:
        image = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    ok, encoded = cv2.imencode(".png", image, png_params(level))
    if not ok:
        raise RuntimeError(f"PNG encoding failed for an image of shape {image.shape}")
    return encoded.tobytes()


def png_bytes(image: np.ndarray, level: int = DEFAULT_PNG_LEVEL) -> bytes:
    with timed("encode"):
        return _png(image, level)


class _Pool:
    """One small thread pool per process, made again after a fork (threads do not survive it)."""

    def __init__(self) -> None:
        self._pid = -1
        self._executor: ThreadPoolExecutor | None = None

    def get(self) -> ThreadPoolExecutor:
        if self._executor is None or self._pid != os.getpid():
            self._executor = ThreadPoolExecutor(_ENCODE_THREADS, thread_name_prefix="png")
            self._pid = os.getpid()
        return self._executor


_pool = _Pool()


def encode_view(
    view: View, prefix: str = "", level: int = DEFAULT_PNG_LEVEL, parallel: bool = True
) -> dict[str, bytes]:
    """``<prefix>rgb.png depth.png seg.png semantic.png`` of one rendered view, plus
    ``depth_sensor.png`` and ``rgb_clean.png`` when it has them; the images are encoded on a
    small thread pool unless ``parallel`` is false (same bytes)."""
    jobs = {  # part name -> (image, whether it is RGB: stored as OpenCV's BGR)
        f"{prefix}rgb.png": (view.rgb, True),
        f"{prefix}depth.png": (view.depth, False),
        f"{prefix}seg.png": (view.instance, False),
        f"{prefix}semantic.png": (view.semantic, False),
    }
    if view.depth_sensor is not None:
        jobs[f"{prefix}depth_sensor.png"] = (view.depth_sensor, False)
    if view.rgb_clean is not None:
        jobs[f"{prefix}rgb_clean.png"] = (view.rgb_clean, True)
    with timed("encode"):
        if not parallel or _ENCODE_THREADS < 2:
            return {name: _png(image, level, rgb) for name, (image, rgb) in jobs.items()}
        pool = _pool.get()
        futures = {
            name: pool.submit(_png, image, level, rgb) for name, (image, rgb) in jobs.items()
        }
        return {name: future.result() for name, future in futures.items()}


def metadata_bytes(metadata: SampleMetadata | Mapping[str, Any]) -> bytes:
    """Strict JSON: writers refuse ``NaN``/``Infinity`` (datagen.safe_json), so a non-finite
    value fails here, naming where it is, instead of the sample being refused on the bus."""
    with timed("encode"):
        try:
            return json.dumps(
                metadata, sort_keys=True, separators=(",", ":"), allow_nan=False
            ).encode()
        except ValueError:
            raise ValueError(
                f"sample metadata {_non_finite_path(metadata)} is not finite"
            ) from None


def _non_finite_path(value: Any, path: str = "") -> str:
    if isinstance(value, float) and not np.isfinite(value):
        return f"{path or '.'} = {value}"
    items = (
        value.items()
        if isinstance(value, dict)
        else enumerate(value)
        if isinstance(value, list | tuple)
        else ()
    )
    for key, item in items:
        if found := _non_finite_path(
            item, f"{path}.{key}" if isinstance(key, str) else f"{path}[{key}]"
        ):
            return found
    return ""


POSE_CONVENTION = (
    "camera-to-world per frame: tx ty tz qx qy qz qw; world z up (metres, the floor plan's "
    "origin); camera axes OpenCV (x right, y down, z forward)"
)
NED_POSE_CONVENTION = (
    "camera-to-world per frame: tx ty tz qx qy qz qw, TartanAir's pose_left.txt convention: world "
    "NED (x along the z-up world's x, y = -y, z = -z: down; metres, the floor plan's origin); "
    "camera axes NED (x forward, y right, z down)"
)
# world NED from the z-up world: a half turn about x (x north, y east, z down)
NED_WORLD = np.diag([1.0, -1.0, -1.0])
# a NED camera's axes (x forward, y right, z down) in OpenCV's (x right, y down, z forward):
# TartanAir's evaluation tools turn their poses into OpenCV's with the same matrix
NED_CAMERA_IN_OPENCV = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])


def _pose_lines(camera_to_world: list[np.ndarray]) -> bytes:
    """One line per 4x4 pose: the position and the unit quaternion (w >= 0)."""
    from scipy.spatial.transform import Rotation

    lines = []
    for pose in camera_to_world:
        q = Rotation.from_matrix(pose[:3, :3]).as_quat()
        q = -q if q[3] < 0 else q
        lines.append(" ".join(f"{v:.7f}" for v in [*pose[:3, 3], *q]))
    return ("\n".join(lines) + "\n").encode()


def pose_file(world_to_camera: list[np.ndarray]) -> bytes:
    """A camera's poses in TartanAir's line format (``POSE_CONVENTION``: OpenCV camera axes in
    the z-up world, not TartanAir's NED), one line per frame."""
    return _pose_lines([np.linalg.inv(e) for e in world_to_camera])


def ned_poses(world_to_camera: list[np.ndarray]) -> list[np.ndarray]:
    """4x4 camera-to-world poses in ``NED_POSE_CONVENTION`` of OpenCV world-to-camera ones."""
    poses = []
    for extrinsics in world_to_camera:
        camera_to_world = np.linalg.inv(extrinsics)
        pose = np.eye(4)
        pose[:3, :3] = NED_WORLD @ camera_to_world[:3, :3] @ NED_CAMERA_IN_OPENCV
        pose[:3, 3] = NED_WORLD @ camera_to_world[:3, 3]
        poses.append(pose)
    return poses


def pose_file_ned(world_to_camera: list[np.ndarray]) -> bytes:
    """A camera's poses as TartanAir's own files have them (``NED_POSE_CONVENTION``)."""
    return _pose_lines(ned_poses(world_to_camera))
