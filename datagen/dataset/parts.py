"""A sample's parts decoded: the encoded bytes of each named part (``rgb.png``, ``json``,
``f0003.d0.flow.png``, ...) made arrays and dicts (:func:`decode_parts`), PNGs on a small
thread pool. Hostile input: every image and JSON part is bounded before it is decoded
(``datagen.images``, ``datagen.safe_json``)."""

from __future__ import annotations

import functools
import os
import re
import sys
from concurrent.futures import ThreadPoolExecutor
from typing import Any, cast

import cv2
import numpy as np

from datagen.dataset.flow_png import decode_flow_image
from datagen.dataset.manifest import DatasetError
from datagen.dataset.part_rules import (
    CAMERA_NAME,
    IMAGE_KINDS,
    IMAGE_PARTS,
    Decoding,
    PartRule,
    image_rule,
)
from datagen.images import ImageInputError, decode_image
from datagen.records import SampleMetadata
from datagen.safe_json import JsonInputError, loads_bounded

_COLOUR_PARTS = ("rgb.png", "rgb_clean.png")  # stored BGR by OpenCV, returned RGB


def _other_camera(decoding: Decoding, match: re.Match[str]) -> dict[str, Any]:
    return decoding.cameras.setdefault(match[1], {})


# another camera of a sample: wrist.rgb.png, view1.depth.png, post.seg.png, ... (after the
# formats' rules: a film's frame3.rgb.png or an episode's f0003.rgb.png is theirs)
OTHER_CAMERAS = image_rule(rf"({CAMERA_NAME})\.({IMAGE_KINDS})\.png", _other_camera)


@functools.cache
def part_rules() -> tuple[PartRule, ...]:
    """The rules of every registered metadata format's parts (``PARTS`` in its module), each
    once, in the formats' order, then the other cameras' images."""
    from datagen.registries import METADATA_FORMATS

    rules: dict[PartRule, None] = {}
    for metadata_format in METADATA_FORMATS.values():
        rules |= dict.fromkeys(metadata_format.parts())
    return (*rules, OTHER_CAMERAS)


def decode_parts(parts: dict[str, bytes]) -> dict[str, Any]:
    """Encoded parts -> arrays: rgb HxWx3 uint8 RGB, depth HxW uint16 mm, seg HxW instance ids,
    semantic HxW class ids, meta dict; where the build made them, depth_sensor HxW uint16 mm
    (0 = no reading) and rgb_clean HxWx3 uint8 RGB; unknown parts stay bytes under their own
    name. The parts of each metadata format are read by its rules (:func:`part_rules`).

    The images of a sample's other cameras are under ``views`` by camera name
    (``item["views"]["view1"]["rgb"]``, ``["wrist"]``, ...; the main camera's stay at the top).
    Navigation episodes also get ``frames`` (a list in time order of dicts with rgb, depth, seg,
    semantic and ``meta``, the frame's record), ``map`` (RGB picture) and ``occupancy`` (bool
    grid, True = occupied). Aerial episodes get ``frames`` whose dicts hold ``cameras`` (camera
    name -> rgb, depth, seg, semantic and, but for the last frame, ``flow`` (H, W, 2) float32
    pixels with ``flow_valid``) and ``meta``; ``map`` and ``side`` (RGB pictures),
    ``occupancy`` (bool voxels (nz, ny, nx), True = occupied) with ``occupancy_resolution``
    (metres), ``poses`` and ``poses_ned`` (camera name -> (T, 7) tx ty tz qx qy qz qw, conventions
    in ``meta["poses_convention"]``), ``imu`` (``d<k>`` -> drone k's IMU stream). A recorded
    grasp attempt gets ``trajectory``: the arrays of its ``trajectory.npz`` and its ``names``
    (``datagen.dataset.trajectory``), with ``frames`` (a list in time order of dicts with
    ``time``, ``rgb`` and, if filmed, ``wrist_rgb``) when it was filmed. The PNGs of one call
    are decoded on a small thread pool (OpenCV releases the GIL)."""
    decoding = Decoding()
    item = decoding.item
    rules = part_rules()
    for name, data in parts.items():
        if name == "json":
            item["meta"] = metadata_of(data, "part 'json'")
        elif name in IMAGE_PARTS:
            decoding.image(item, IMAGE_PARTS[name], name, data)
        elif not any(rule.apply(decoding, name, data) for rule in rules):
            item[name] = data
    jobs = decoding.jobs
    pool = _decoder_pool() if len(jobs) > 1 else None
    images = (
        pool.map(lambda job: _decode_png(job[2], job[3]), jobs)
        if pool
        else [_decode_png(job[2], job[3]) for job in jobs]
    )
    for (into, field, _, _), image in zip(jobs, images, strict=True):
        if field == "flow":
            into["flow"], into["flow_valid"] = decode_flow_image(image)
        else:
            into[field] = image > 0 if field == "occupancy" else image
    if decoding.cameras:
        item["views"] = decoding.cameras
    if decoding.film:
        _attach_film(item, decoding.film)
    if decoding.frames:
        frames = decoding.frames
        records = item.get("meta", {}).get("frames", [])
        records = records if isinstance(records, list) else []
        item["frames"] = [
            frames[k] | ({"meta": records[k]} if k < len(records) else {}) for k in sorted(frames)
        ]
    return item


def _attach_film(item: dict[str, Any], film: dict[int, dict[str, Any]]) -> None:
    trajectory = item.get("trajectory")
    if not trajectory:
        raise DatasetError(
            "frame<k>.rgb.png parts do not match any frame times: no part 'trajectory.npz'"
        )
    times = trajectory["frame_time"]
    if sorted(film) != list(range(len(times))):
        raise DatasetError(
            f"frame<k>.rgb.png parts {sorted(film)[:5]}... do not match the {len(times)} frame "
            "times of part 'trajectory.npz'"
        )
    trajectory["frames"] = [film[k] | {"time": float(times[k])} for k in sorted(film)]


def metadata_of(data: bytes, what: str) -> SampleMetadata:
    """A sample's ``json`` part as a dict (``loads_bounded``), or DatasetError naming ``what``."""
    try:
        meta = loads_bounded(data, what=what)
    except JsonInputError as exc:
        raise DatasetError(str(exc)) from None
    if not isinstance(meta, dict):
        raise DatasetError(f"{what}: a JSON {type(meta).__name__}, expected an object")
    return cast(SampleMetadata, meta)  # a reader checks the keys it uses


_pool: tuple[int, ThreadPoolExecutor | None] | None = None


def _decoder_pool() -> ThreadPoolExecutor | None:
    """One pool per process (a pool inherited through fork has no threads), sized so that the
    DataLoader workers' threads together do not exceed the cores; None = decode inline."""
    global _pool
    if _pool is None or _pool[0] != os.getpid():
        threads = min(4, os.cpu_count() or 1)
        if "torch" in sys.modules:
            from torch.utils.data import get_worker_info

            info = get_worker_info()
            threads = max(1, threads // info.num_workers) if info else threads
        _pool = (os.getpid(), ThreadPoolExecutor(threads) if threads > 1 else None)
    return _pool[1]


def _decode_png(name: str, data: bytes) -> np.ndarray:
    try:
        image = decode_image(data, what=f"part {name!r}")
    except ImageInputError as exc:
        raise DatasetError(str(exc)) from None
    if name in _COLOUR_PARTS and image.ndim == 3:
        code = cv2.COLOR_BGRA2RGB if image.shape[2] == 4 else cv2.COLOR_BGR2RGB
        image = cv2.cvtColor(image, code)
    return image
