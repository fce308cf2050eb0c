"""Reading a datagen dataset: ``load(dir)`` for training code, ``verify(dir)`` for checksums
(sample by sample: ``datagen.dataset.integrity``).

``load`` reads the tar headers of the shards listed in ``manifest.json`` once (``scan_members``:
about 1.5 s per 10^5 samples of 5 parts), keeping each
member's byte offset; items are then read with ``os.pread`` from file handles opened lazily in
each process, so random access is cheap and the dataset pickles into DataLoader workers.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import sys
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, cast

import cv2
import numpy as np

from datagen.dataset.episode_parts import imu_for_frame, imu_stream, pose_lines, voxel_grid
from datagen.dataset.flow_png import decode_flow_image
from datagen.dataset.integrity import verify_dataset
from datagen.dataset.manifest import DatasetError, read_manifest
from datagen.dataset.trajectory import decode_trajectory
from datagen.images import ImageInputError, decode_image
from datagen.records import SampleMetadata
from datagen.safe_json import JsonInputError, loads_bounded
from datagen.shard_members import open_regular, read_members
from datagen.shards import member_key

# part name -> item field, for the parts decoded as images (depth_sensor.png: the sensor
# model's depth, rgb_clean.png: colour before the camera effects; only where the build made them)
_IMAGES = {
    "rgb.png": "rgb",
    "depth.png": "depth",
    "seg.png": "seg",
    "semantic.png": "semantic",
    "depth_sensor.png": "depth_sensor",
    "rgb_clean.png": "rgb_clean",
}
_COLOUR_PARTS = ("rgb.png", "rgb_clean.png")  # stored BGR by OpenCV, returned RGB
_KINDS = "rgb|rgb_clean|depth|depth_sensor|seg|semantic"

_FRAME_PART = re.compile(rf"^f(\d{{4}})\.({_KINDS})\.png$")
# a frame of one of several cameras (aerial episodes): f0003.d0.rgb.png, f0003.d1_down.flow.png
_CAMERA_FRAME_PART = re.compile(rf"^f(\d{{4}})\.([A-Za-z][\w-]*)\.({_KINDS}|flow)\.png$")
_POSES_PART = re.compile(r"^(poses|poses_ned)\.([A-Za-z][\w-]*)\.txt$")
_IMU_PART = re.compile(r"^imu\.(d\d+)\.npz$")
# another camera of a sample: wrist.rgb.png, view1.depth.png, post.seg.png, ...
_CAMERA_PART = re.compile(rf"^([A-Za-z][\w-]*)\.({_KINDS})\.png$")
# a grasp attempt's film: frame3.rgb.png (workspace camera), frame3.wrist.rgb.png
_FILM_PART = re.compile(r"^frame(\d+)\.(?:(wrist)\.)?rgb\.png$")


def decode_parts(parts: dict[str, bytes]) -> dict[str, Any]:
    """Encoded parts -> arrays: rgb HxWx3 uint8 RGB, depth HxW uint16 mm, seg HxW instance ids,
    semantic HxW class ids, meta dict; where the build made them, depth_sensor HxW uint16 mm
    (0 = no reading) and rgb_clean HxWx3 uint8 RGB; unknown parts stay bytes under their own
    name.

    The images of a sample's other cameras are under ``views`` by camera name
    (``item["views"]["view1"]["rgb"]``, ``["wrist"]``, ...; the main camera's stay at the top).
    Navigation episodes also get ``frames`` (a list in time order of dicts with rgb, depth, seg,
    semantic and ``meta``, the frame's record), ``map`` (RGB picture) and ``occupancy`` (bool
    grid, True = occupied). Aerial episodes get ``frames`` whose dicts hold ``cameras`` (camera
    name -> rgb, depth, seg, semantic and, but for the last frame, ``flow`` (H, W, 2) float32
    pixels with ``flow_valid``) and ``meta``; ``map`` and ``side`` (RGB pictures),
    ``occupancy`` (bool voxels (nz, ny, nx), True = occupied) with ``occupancy_resolution``
    (metres), ``poses`` and ``poses_ned`` (camera name -> (T, 7) tx ty tz qx qy qz qw, conventions
    in ``meta["poses_convention"]``), ``imu`` (``d<k>`` -> drone k's IMU stream). A recorded grasp attempt gets ``trajectory``: the arrays of its
    ``trajectory.npz`` and its ``names`` (``datagen.dataset.trajectory``), with ``frames`` (a list
    in time order of dicts with ``time``, ``rgb`` and, if filmed, ``wrist_rgb``) when it was
    filmed. The PNGs of one call are decoded on a small thread pool (OpenCV releases the GIL)."""
    item: dict[str, Any] = {}
    frames: dict[int, dict[str, Any]] = {}
    cameras: dict[str, dict[str, Any]] = {}
    film: dict[int, dict[str, Any]] = {}
    jobs: list[tuple[dict[str, Any], str, str, bytes]] = []  # (into, field, image kind, data)
    for name, data in parts.items():
        if name == "json":
            item["meta"] = metadata_of(data, "part 'json'")
        elif name in _IMAGES:
            jobs.append((item, _IMAGES[name], name, data))
        elif name == "trajectory.npz":
            item["trajectory"] = decode_trajectory(data)
        elif match := _FILM_PART.match(name):
            field = "wrist_rgb" if match[2] else "rgb"
            jobs.append((film.setdefault(int(match[1]), {}), field, "rgb.png", data))
        elif match := _FRAME_PART.match(name):
            kind = f"{match[2]}.png"
            jobs.append((frames.setdefault(int(match[1]), {}), _IMAGES[kind], kind, data))
        elif match := _CAMERA_FRAME_PART.match(name):
            kind = f"{match[3]}.png"
            into = (
                frames.setdefault(int(match[1]), {})
                .setdefault("cameras", {})
                .setdefault(match[2], {})
            )
            jobs.append((into, _IMAGES.get(kind, "flow"), kind, data))
        elif match := _POSES_PART.match(name):
            item.setdefault(match[1], {})[match[2]] = pose_lines(data, name)
        elif match := _IMU_PART.match(name):
            item.setdefault("imu", {})[match[1]] = imu_stream(data, name)
        elif name == "occupancy.npz":
            item["occupancy"], item["occupancy_resolution"] = voxel_grid(data)
        elif match := _CAMERA_PART.match(name):
            kind = f"{match[2]}.png"
            jobs.append((cameras.setdefault(match[1], {}), _IMAGES[kind], kind, data))
        elif name in ("map.png", "side.png"):
            jobs.append((item, name[:-4], "rgb.png", data))
        elif name == "occupancy.png":
            jobs.append((item, "occupancy", name, data))
        else:
            item[name] = data
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
    if cameras:
        item["views"] = cameras
    if film:
        _attach_film(item, film)
    if frames:
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


class ShardDataset:
    """Map-style dataset over finalized shards; items in key order."""

    def __init__(self, root: str | Path, verify: bool = False):
        self.root = Path(root)
        self.manifest = read_manifest(self.root)
        if verify:
            _raise_problems(verify_dataset(self.root, manifest=self.manifest))
        self.shards = [str(s["name"]) for s in self.manifest["shards"]]
        # key -> [(shard number, data offset, size, part name)]
        members: dict[str, list[tuple[int, int, int, str]]] = {}
        for i, name in enumerate(self.shards):
            path = self.root / name
            try:
                shard_members = read_members(path)  # DatasetError naming a bad member
            except FileNotFoundError:
                raise DatasetError(
                    f"{self.root}: shard {name} listed in the manifest is missing"
                ) from None
            listed = self.manifest["shards"][i].get("bytes")
            if listed is not None and path.stat().st_size != listed:
                raise DatasetError(
                    f"{path}: {path.stat().st_size} bytes, the manifest lists {listed} "
                    "(truncated or altered)"
                )
            for m in shard_members:
                key = member_key(m.name)
                members.setdefault(key, []).append(
                    (i, m.offset_data, m.size, m.name[len(key) + 1 :])
                )
        self.keys = sorted(members)
        self._members = [members[k] for k in self.keys]
        expected = self.manifest.get("samples")
        if expected is not None and expected != len(self.keys):
            raise DatasetError(
                f"{self.root}: manifest says {expected} samples, shards hold {len(self.keys)}"
            )
        self._fds: dict[int, int] = {}
        self._pid = os.getpid()

    def __len__(self) -> int:
        return len(self.keys)

    def __getitem__(self, i: int) -> dict[str, Any]:
        try:
            item = decode_parts(self.raw(i))
        except DatasetError as exc:
            raise DatasetError(f"{self.root}: sample {self.keys[i]}: {exc}") from None
        item["key"] = self.keys[i]
        return item

    def __iter__(self) -> Iterator[dict[str, Any]]:
        for i in range(len(self)):
            yield self[i]

    def raw(self, i: int, parts: set[str] | None = None) -> dict[str, bytes]:
        """The encoded parts of item ``i`` as stored; only those named in ``parts`` if given."""
        return {
            part: self._read(shard, offset, size)
            for shard, offset, size, part in self._members[i]
            if parts is None or part in parts
        }

    def part_names(self, i: int) -> list[str]:
        return [member[3] for member in self._members[i]]

    def location(self, i: int) -> tuple[int, int]:
        """(shard number, byte offset) of item ``i``'s first member: its place in storage."""
        return min(member[:2] for member in self._members[i])

    def metadata(self, i: int) -> SampleMetadata:
        """Only the JSON metadata of item ``i`` (no image decoding)."""
        for shard, offset, size, part in self._members[i]:
            if part == "json":
                return metadata_of(
                    self._read(shard, offset, size), f"{self.root}: {self.keys[i]}.json"
                )
        raise DatasetError(f"{self.root}: sample {self.keys[i]} has no json part")

    def shard_paths(self) -> list[str]:
        return [str(self.root / name) for name in self.shards]

    def close(self) -> None:
        if self._pid == os.getpid():
            for fd in self._fds.values():
                os.close(fd)
        self._fds = {}

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_fds"] = {}
        return state

    def __del__(self) -> None:
        with contextlib.suppress(OSError, AttributeError):
            self.close()

    def _read(self, shard: int, offset: int, size: int) -> bytes:
        if self._pid != os.getpid():  # forked (e.g. a DataLoader worker): own handles
            self._fds, self._pid = {}, os.getpid()
        fd = self._fds.get(shard)
        if fd is None:
            fd = self._fds[shard] = open_regular(self.root / self.shards[shard])
        data = os.pread(fd, size, offset)
        if len(data) != size:
            raise DatasetError(f"{self.shards[shard]}: truncated member at byte {offset}")
        return data


class FrameDataset:
    """Map-style dataset of the single frames of episodes, in (episode, camera, frame) order: a
    navigation episode's one camera, an aerial episode's every camera (``d0``, ``d0_down``, ...).

    Item: rgb, depth, seg, semantic (aerial: ``flow`` and ``flow_valid`` but on the last frame),
    ``meta`` (the frame's record: poses, commands or agent states, goal, ...), ``camera`` (the
    camera's record, its extrinsics at this frame), ``episode`` (its key), ``frame`` (its
    number), ``view`` (the camera's name; "" for navigation), aerial ``imu`` (its drone's samples
    since the previous frame, :func:`~datagen.dataset.episode_parts.imu_for_frame`) and ``key``
    (``<episode>/f<frame>`` or ``<episode>/f<frame>.<camera>``). Only the frame's own images are
    read and decoded."""

    def __init__(self, root: str | Path, verify: bool = False):
        self.episodes = ShardDataset(root, verify)
        self.index: list[tuple[int, int, str]] = []
        for i in range(len(self.episodes)):
            frames = set()
            for part in self.episodes.part_names(i):
                if m := _FRAME_PART.match(part):
                    frames.add(("", int(m[1])))
                elif m := _CAMERA_FRAME_PART.match(part):
                    frames.add((m[2], int(m[1])))
            self.index.extend((i, k, camera) for camera, k in sorted(frames))
        if len(self.episodes) and not self.index:
            raise DatasetError(
                f"{root}: no episode frames (fNNNN.*.png parts); not navigation or aerial data"
            )

    def __len__(self) -> int:
        return len(self.index)

    @functools.lru_cache(maxsize=8)  # noqa: B019 - a handful of episodes' JSON, per process
    def _episode_meta(self, i: int) -> SampleMetadata:
        return self.episodes.metadata(i)

    def __getitem__(self, j: int) -> dict[str, Any]:
        i, k, view = self.index[j]
        prefix = f"f{k:04d}." + (f"{view}." if view else "")
        names = {prefix + name for name in [*_IMAGES, "flow.png"]}
        raw = self.episodes.raw(i, names & set(self.episodes.part_names(i)))
        item = decode_parts(
            {name[len(prefix) :]: data for name, data in raw.items() if name != prefix + "flow.png"}
        )
        meta = self._episode_meta(i)
        record = meta["frames"][k]
        if view:
            if prefix + "flow.png" in raw:
                flow = decode_parts({f"f0000.{view}.flow.png": raw[prefix + "flow.png"]})
                item |= {n: flow["frames"][0]["cameras"][view][n] for n in ("flow", "flow_valid")}
            camera = meta["cameras"][view] | record["cameras"][view]
            item["imu"] = imu_for_frame(self.episodes, i, meta, view, k)
        else:
            camera = meta["camera"]
        key = f"{self.episodes.keys[i]}/f{k:04d}" + (f".{view}" if view else "")
        item.update(
            meta=record, camera=camera, episode=self.episodes.keys[i], frame=k, view=view, key=key
        )
        return item

    def __iter__(self) -> Iterator[dict[str, Any]]:
        for j in range(len(self)):
            yield self[j]


def load(root: str | Path, verify: bool = False) -> ShardDataset:
    """One item per sample: a frame, a grasp attempt, or a whole navigation episode.
    ``verify=True`` first re-reads every shard and checks each sample against the manifest's
    digests (as ``datagen verify``), raising DatasetError that lists every problem."""
    return ShardDataset(root, verify)


def load_frames(root: str | Path, verify: bool = False) -> FrameDataset:
    """The frames of a navigation or aerial dataset as one flat map-style dataset
    (``verify``: as in ``load``)."""
    return FrameDataset(root, verify)


def verify(root: str | Path) -> dict[str, Any]:
    """Re-reads every shard: sizes, sha256, each sample's digest, the keys of samples 0..N-1
    each once; raises DatasetError listing every problem, else returns the manifest."""
    return _raise_problems(verify_dataset(root))


def check_complete(root: str | Path, expected: int, build_id: str | None = None) -> dict[str, Any]:
    """:func:`verify` for ``expected`` samples of build ``build_id`` (if given): the coordinator's
    check before it reports success."""
    return _raise_problems(verify_dataset(root, expected=expected, build_id=build_id))


def _raise_problems(report) -> dict[str, Any]:
    if report.problems:
        raise DatasetError(f"{report.root}: " + "; ".join(report.problems))
    return report.manifest
