"""Reading a datagen dataset: ``load(dir)`` for training code, ``verify(dir)`` for checksums.

``load`` reads the tar headers of the shards listed in ``manifest.json`` once (``scan_members``:
about 1.5 s per 10^5 samples of 5 parts), keeping each
member's byte offset; items are then read with ``os.pread`` from file handles opened lazily in
each process, so random access is cheap and the dataset pickles into DataLoader workers.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import re
import sys
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from datagen.sample import sample_key
from datagen.shards import MANIFEST, file_sha256, keys_sha256, member_key, scan_members

# part name -> item field, for the parts decoded as images
_IMAGES = {"rgb.png": "rgb", "depth.png": "depth", "seg.png": "seg", "semantic.png": "semantic"}


class DatasetError(ValueError):
    """The directory is not a (valid) datagen dataset; the text says why."""


def read_manifest(root: str | Path) -> dict[str, Any]:
    """``root/manifest.json``, checked to be a datagen manifest: a ``shards`` list of records
    naming files in ``root``, a ``samples`` count. Raises DatasetError naming the path."""
    path = Path(root) / MANIFEST
    try:
        found = None if Path(root).is_dir() else Path(root).exists()
        text = path.read_text(encoding="utf-8") if found is None and path.is_file() else None
    except OSError as exc:
        raise DatasetError(f"{exc.filename or path}: cannot read it: {exc.strerror}") from None
    except UnicodeDecodeError as exc:
        raise DatasetError(f"{path}: not valid JSON: {exc}") from None
    if found is not None:
        found = "not a directory" if found else "no such directory"
        raise DatasetError(f"{root}: {found}; expected a dataset directory (with {MANIFEST})")
    if text is None:
        raise DatasetError(f"{root} is not a datagen dataset: no {MANIFEST} (not finalized?)")
    try:
        manifest = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise DatasetError(f"{path}: not valid JSON: {exc}") from None
    if not isinstance(manifest, dict) or not isinstance(manifest.get("shards"), list):
        raise DatasetError(f"{path}: no 'shards' list; not a datagen manifest")
    for i, record in enumerate(manifest["shards"]):
        if problem := _shard_record_problem(record):
            raise DatasetError(f"{path}: shards[{i}]: {problem}; not a datagen manifest")
    samples = manifest.get("samples")
    if samples is not None and (type(samples) is not int or samples < 0):
        raise DatasetError(f"{path}: 'samples' is {repr(samples)[:60]}, expected a count")
    return manifest


def _shard_record_problem(record: Any) -> str | None:
    """What is wrong with one record of a manifest's ``shards``, or None."""
    if not isinstance(record, dict):
        return f"expected a record with a 'name', got {repr(record)[:60]}"
    name = record.get("name")
    if not isinstance(name, str) or name in ("", ".", "..") or any(c in name for c in "/\\\0"):
        return f"'name' is {repr(name)[:60]}, expected the file name of a shard in the dataset"
    for count in ("bytes", "samples"):
        value = record.get(count, 0)
        if type(value) is not int or value < 0:
            return f"'{count}' is {repr(value)[:60]}, expected a count"
    return None


_FRAME_PART = re.compile(r"^f(\d{4})\.(rgb|depth|seg|semantic)\.png$")


def decode_parts(parts: dict[str, bytes]) -> dict[str, Any]:
    """Encoded parts -> arrays: rgb HxWx3 uint8 RGB, depth HxW uint16 mm, seg HxW instance ids,
    semantic HxW class ids, meta dict; unknown parts stay bytes under their own name.

    Navigation episodes also get ``frames`` (a list in time order of dicts with rgb, depth, seg,
    semantic and ``meta``, the frame's record), ``map`` (RGB picture) and ``occupancy`` (bool
    grid, True = occupied). The PNGs of one call are decoded on a small thread pool (OpenCV
    releases the GIL)."""
    item: dict[str, Any] = {}
    frames: dict[int, dict[str, Any]] = {}
    jobs: list[tuple[dict[str, Any], str, str, bytes]] = []  # (into, field, image kind, data)
    for name, data in parts.items():
        if name == "json":
            item["meta"] = json.loads(data.decode("utf-8"))
        elif name in _IMAGES:
            jobs.append((item, _IMAGES[name], name, data))
        elif match := _FRAME_PART.match(name):
            kind = f"{match[2]}.png"
            jobs.append((frames.setdefault(int(match[1]), {}), _IMAGES[kind], kind, data))
        elif name == "map.png":
            jobs.append((item, "map", "rgb.png", data))
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
        into[field] = image > 0 if field == "occupancy" else image
    if frames:
        records = item.get("meta", {}).get("frames", [])
        item["frames"] = [
            frames[k] | ({"meta": records[k]} if k < len(records) else {}) for k in sorted(frames)
        ]
    return item


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
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise DatasetError(f"part {name!r} is not a decodable image")
    if name == "rgb.png" and image.ndim == 3:
        code = cv2.COLOR_BGRA2RGB if image.shape[2] == 4 else cv2.COLOR_BGR2RGB
        image = cv2.cvtColor(image, code)
    return image


class ShardDataset:
    """Map-style dataset over finalized shards; items in key order."""

    def __init__(self, root: str | Path):
        self.root = Path(root)
        self.manifest = read_manifest(self.root)
        self.shards = [str(s["name"]) for s in self.manifest["shards"]]
        # key -> [(shard number, data offset, size, part name)]
        members: dict[str, list[tuple[int, int, int, str]]] = {}
        for i, name in enumerate(self.shards):
            path = self.root / name
            if not path.is_file():
                raise DatasetError(f"{self.root}: shard {name} listed in the manifest is missing")
            listed = self.manifest["shards"][i].get("bytes")
            if listed is not None and path.stat().st_size != listed:
                raise DatasetError(
                    f"{path}: {path.stat().st_size} bytes, the manifest lists {listed} "
                    "(truncated or altered)"
                )
            for m in scan_members(path):
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
        item = decode_parts(self.raw(i))
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

    def metadata(self, i: int) -> dict[str, Any]:
        """Only the JSON metadata of item ``i`` (no image decoding)."""
        for shard, offset, size, part in self._members[i]:
            if part == "json":
                return json.loads(self._read(shard, offset, size))
        raise DatasetError(f"item {i} has no json part")

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
            fd = self._fds[shard] = os.open(self.root / self.shards[shard], os.O_RDONLY)
        data = os.pread(fd, size, offset)
        if len(data) != size:
            raise DatasetError(f"{self.shards[shard]}: truncated member at byte {offset}")
        return data


class FrameDataset:
    """Map-style dataset of the single frames of navigation episodes, in (episode, frame) order.

    Item: rgb, depth, seg, semantic, ``meta`` (the frame's record: pose, command, goal, ...),
    ``camera`` (the episode's camera record), ``episode`` (its key), ``frame`` (its number) and
    ``key`` (``<episode>/f<frame>``). Only the frame's own images are read and decoded."""

    def __init__(self, root: str | Path):
        self.episodes = ShardDataset(root)
        self.index: list[tuple[int, int]] = []
        for i in range(len(self.episodes)):
            frames = sorted(
                int(m[1]) for p in self.episodes.part_names(i) if (m := _FRAME_PART.match(p))
            )
            self.index.extend((i, k) for k in dict.fromkeys(frames))
        if len(self.episodes) and not self.index:
            raise DatasetError(
                f"{root}: no episode frames (fNNNN.*.png parts); not navigation data"
            )

    def __len__(self) -> int:
        return len(self.index)

    @functools.lru_cache(maxsize=8)  # noqa: B019 - a handful of episodes' JSON, per process
    def _episode_meta(self, i: int) -> dict[str, Any]:
        return self.episodes.metadata(i)

    def __getitem__(self, j: int) -> dict[str, Any]:
        i, k = self.index[j]
        prefix = f"f{k:04d}."
        raw = self.episodes.raw(i, {prefix + name for name in _IMAGES})
        item = decode_parts({name[len(prefix) :]: data for name, data in raw.items()})
        meta = self._episode_meta(i)
        item.update(
            meta=meta["frames"][k],
            camera=meta["camera"],
            episode=self.episodes.keys[i],
            frame=k,
            key=f"{self.episodes.keys[i]}/f{k:04d}",
        )
        return item

    def __iter__(self) -> Iterator[dict[str, Any]]:
        for j in range(len(self)):
            yield self[j]


def load(root: str | Path) -> ShardDataset:
    """One item per sample: a frame, a grasp attempt, or a whole navigation episode."""
    return ShardDataset(root)


def load_frames(root: str | Path) -> FrameDataset:
    """The frames of a navigation dataset as one flat map-style dataset."""
    return FrameDataset(root)


def verify(root: str | Path) -> dict[str, Any]:
    """Recomputes every shard's sha256 and size and the keys digest; raises DatasetError on
    any mismatch, else returns the manifest."""
    root = Path(root)
    manifest = read_manifest(root)
    problems = []
    for shard in manifest["shards"]:
        path = root / shard["name"]
        if not path.is_file():
            problems.append(f"{shard['name']}: missing")
            continue
        if path.stat().st_size != shard.get("bytes"):
            problems.append(
                f"{shard['name']}: {path.stat().st_size} bytes, manifest says {shard.get('bytes')}"
            )
        if file_sha256(path) != shard.get("sha256"):
            problems.append(f"{shard['name']}: sha256 differs from the manifest")
    if not problems and "keys_sha256" in manifest:
        keys = ShardDataset(root).keys
        if keys_sha256(keys) != manifest["keys_sha256"]:
            problems.append("keys_sha256 differs from the keys in the shards")
    if problems:
        raise DatasetError(f"{root}: " + "; ".join(problems))
    return manifest


def check_complete(root: str | Path, expected: int, build_id: str | None = None) -> dict[str, Any]:
    """:func:`verify`, and the shards hold exactly the keys of samples 0..expected-1, each once
    (the manifest of build ``build_id``, if given); raises DatasetError saying what is missing,
    extra or duplicated."""
    manifest = verify(root)
    keys = ShardDataset(root).keys
    wanted = {sample_key(i) for i in range(expected)}
    seen: set[str] = set()
    duplicated = sorted({k for k in keys if k in seen or seen.add(k)})
    missing, extra = sorted(wanted - seen), sorted(seen - wanted)
    problems = [
        f"{label} {len(items)}: {', '.join(items[:10])}{' ...' if len(items) > 10 else ''}"
        for label, items in (("missing", missing), ("extra", extra), ("duplicated", duplicated))
        if items
    ]
    if manifest.get("samples") != expected:
        problems.append(f"the manifest says {manifest.get('samples')} samples, expected {expected}")
    if build_id is not None and manifest.get("build_id") != build_id:
        problems.append(f"the manifest is of build {manifest.get('build_id')!r}, not {build_id!r}")
    if problems:
        raise DatasetError(f"{root}: " + "; ".join(problems))
    return manifest
