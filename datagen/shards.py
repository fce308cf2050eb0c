"""The on-disk format of a dataset directory, shared by the writers and the reader.

Shards are WebDataset tars ``shard-{writer_id}-{n:06d}.tar`` with members ``{key}.{part}``;
``manifest.json`` (``dataset_format`` ``DATASET_FORMAT``) lists them (``ShardInfo``: name,
samples, sha256, bytes, and each sample's ``sample_sha256``) with the digest of all keys
(``keys_sha256``), written atomically by ``write_json_durably``. ``read_shard`` re-reads a whole
shard in one pass for its digests, a megabyte at a time, its members read and checked as
``datagen.shard_members`` reads every shard's. The format is specified in
docs/dataset-format.md.

Writing shards (``datagen.writer.shard_writer``), the crash journal and recovery
(``datagen.writer.journal``) and the writer lock (``datagen.writer.lock``) live with the writer.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from datagen.shard_members import MAX_MEMBER_BYTES, Member, members_in, open_regular, scan_members

MANIFEST = "manifest.json"
DATASET_FORMAT_NAME = "datagen.dataset"
DATASET_FORMAT_VERSION = 1  # the newest ``dataset_format`` this code reads and writes
DATASET_FORMAT = f"{DATASET_FORMAT_NAME}/{DATASET_FORMAT_VERSION}"  # manifest.json's
_WRITER_ID = re.compile(r"^[A-Za-z0-9_-]{1,32}\Z")
SHARD_RE = re.compile(r"^shard-(?P<writer>[A-Za-z0-9_-]+)-(?P<n>\d{6})\.tar\Z")


def valid_writer_id(writer_id: str) -> bool:
    return bool(_WRITER_ID.match(writer_id))


def shard_name(writer_id: str, n: int) -> str:
    return f"shard-{writer_id}-{n:06d}.tar"


def member_key(member_name: str) -> str:
    """``000000042.rgb.png`` -> ``000000042`` (WebDataset splits at the first dot)."""
    return member_name.split(".", 1)[0]


@dataclass
class ShardInfo:
    """A shard as the manifest lists it; ``sample_sha256``: key -> ``sample_sha256`` of the
    sample's parts."""

    name: str
    samples: int
    sha256: str
    bytes: int
    sample_sha256: dict[str, str] = field(default_factory=dict)

    def to_json(self) -> dict:
        return asdict(self)


def sample_sha256(parts: Iterable[tuple[str, bytes]]) -> str:
    """The digest of one sample: sha256 over its parts in part-name order, each as the UTF-8
    name, a NUL byte, the size as 8 bytes little-endian, then the bytes. Independent of the tar
    (headers, member order), so it can be checked from the parts as loaded."""
    h = hashlib.sha256()
    for name, data in sorted(parts, key=lambda part: part[0]):
        h.update(_part_header(name, len(data)))
        h.update(data)
    return h.hexdigest()


def _part_header(name: str, size: int) -> bytes:
    return name.encode("utf-8") + b"\0" + size.to_bytes(8, "little")


def fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def keys_sha256(keys: Iterable[str]) -> str:
    """sha256 of the sorted keys, each followed by a newline (UTF-8)."""
    return hashlib.sha256("".join(f"{k}\n" for k in sorted(keys)).encode()).hexdigest()


def write_json_durably(
    out_dir: str | Path, doc: Mapping[str, Any], name: str = MANIFEST, mode: int = 0o644
) -> Path:
    """Writes ``doc`` as JSON into ``out_dir/name`` (the manifest unless named otherwise: the
    build state, an export record) atomically and durably (temp file, fsync, rename, fsync
    dir); on failure the old file is intact and the temp file removed."""
    out = Path(out_dir)
    tmp = out / (name + ".tmp")
    try:
        tmp.unlink(missing_ok=True)  # a link planted there is removed, never written through
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, mode)
        with open(fd, "w", encoding="utf-8") as f:
            json.dump(doc, f, indent=2, sort_keys=True)
            f.write("\n")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, out / name)
    except BaseException:  # a full disk, say: no partial copy left beside the manifest
        tmp.unlink(missing_ok=True)
        raise
    fsync_dir(out)
    return out / name


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


_CHUNK = 1 << 20  # bytes read at a time when hashing


def keys_of_members(members: list[Member], durable_bytes: int | None = None) -> list[str]:
    """Sample keys in member order; with ``durable_bytes``, only samples wholly before it."""
    keys: list[str] = []
    ends: list[int] = []
    for m in members:
        key = member_key(m.name)
        if keys and keys[-1] == key:
            ends[-1] = m.end
        else:
            keys.append(key)
            ends.append(m.end)
    if durable_bytes is None:
        return keys
    return [k for k, end in zip(keys, ends, strict=True) if end <= durable_bytes]


class ShardContents(NamedTuple):
    """A shard as re-read: its sha256 and size, and each sample's (key, ``sample_sha256``) in
    storage order (a key held twice appears twice)."""

    sha256: str
    bytes: int
    samples: list[tuple[str, str]]

    def info(self, name: str) -> ShardInfo:
        return ShardInfo(name, len(self.samples), self.sha256, self.bytes, dict(self.samples))


def read_shard(
    path: str | Path,
    on_sample: Callable[[], None] | None = None,
    max_member_bytes: int = MAX_MEMBER_BYTES,
) -> ShardContents:
    """Reads a shard once, front to back, for its sha256 and every sample's digest, streamed
    (a megabyte at a time); its members checked as ``read_members`` does (DatasetError naming
    the shard and the member). ``on_sample()`` is called after each sample."""
    path = Path(path)
    fd = open_regular(path)
    try:
        members = members_in(path, fd, max_member_bytes)
        whole = hashlib.sha256()
        samples: list[tuple[str, str]] = []
        pos = 0
        for key, group in itertools.groupby(members, key=lambda m: member_key(m.name)):
            parts = list(group)
            samples.append((key, _sample_digest(fd, path, whole, pos, key, parts)))
            pos = parts[-1].end
            if on_sample:
                on_sample()
        while chunk := os.pread(fd, _CHUNK, pos):  # end-of-archive blocks, or whatever follows
            whole.update(chunk)
            pos += len(chunk)
    finally:
        os.close(fd)
    return ShardContents(whole.hexdigest(), pos, samples)


def _sample_digest(fd: int, path: Path, whole, start: int, key: str, parts: list[Member]) -> str:
    """``sample_sha256`` of one sample's members, the shard's bytes from ``start`` to its end fed
    to ``whole`` on the way: read at once if they fit in ``_CHUNK``, else streamed."""
    end = parts[-1].end
    if end - start > _CHUNK:
        _hash_range(fd, path, whole, start, end)
        digest = hashlib.sha256()
        for m in sorted(parts, key=lambda m: m.name):  # sample_sha256's order
            digest.update(_part_header(m.name[len(key) + 1 :], m.size))
            _hash_range(fd, path, digest, m.offset_data, m.offset_data + m.size)
        return digest.hexdigest()
    region = memoryview(os.pread(fd, end - start, start))
    if len(region) != end - start:
        raise OSError(f"{path.name}: changed while it was read")
    whole.update(region)
    return sample_sha256(
        (m.name[len(key) + 1 :], region[m.offset_data - start : m.offset_data - start + m.size])
        for m in parts
    )


def _hash_range(fd: int, path: Path, h, start: int, end: int) -> None:
    """Feeds bytes ``start``..``end`` of the file to ``h``."""
    while start < end:
        chunk = os.pread(fd, min(_CHUNK, end - start), start)
        if not chunk:
            raise OSError(f"{path.name}: changed while it was read")
        h.update(chunk)
        start += len(chunk)


def read_keys(path: Path) -> list[str]:
    """Sample keys in a tar, in order; stops quietly at a truncated tail."""
    return keys_of_members(scan_members(path))


def shards_by_writer(out_dir: str | Path) -> dict[str, list[Path]]:
    """Shard files in ``out_dir``, grouped by writer id, each list sorted by name."""
    found: dict[str, list[Path]] = {}
    for path in sorted(Path(out_dir).glob("shard-*.tar")):
        m = SHARD_RE.match(path.name)
        if m is not None:
            found.setdefault(m["writer"], []).append(path)
    return found
