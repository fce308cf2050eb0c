"""The on-disk format of a dataset directory, shared by the writers and the reader.

Shards are WebDataset tars ``shard-{writer_id}-{n:06d}.tar`` with members ``{key}.{part}``;
``manifest.json`` (``dataset_format`` ``DATASET_FORMAT``) lists them (``ShardInfo``: name,
samples, sha256, bytes, and each sample's ``sample_sha256``) with the digest of all keys
(``keys_sha256``), written atomically by ``write_manifest``. ``scan_members`` reads tar headers
directly (about 15x faster than ``tarfile`` on 10^5 samples) and stops quietly at a truncated
or damaged tail; ``read_shard`` re-reads a whole shard in one pass for its digests. The format
is specified in docs/dataset-format.md.

Writing shards (``datagen.sinks.shard_writer``), the crash journal and recovery
(``datagen.sinks.journal``) and the writer lock (``datagen.sinks.lock``) live with the writer.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import tarfile
import zlib
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

log = logging.getLogger(__name__)

MANIFEST = "manifest.json"
DATASET_FORMAT_NAME = "datagen.dataset"
DATASET_FORMAT_VERSION = 1  # the newest ``dataset_format`` this code reads and writes
DATASET_FORMAT = f"{DATASET_FORMAT_NAME}/{DATASET_FORMAT_VERSION}"  # manifest.json's
_WRITER_ID = re.compile(r"^[A-Za-z0-9_-]{1,32}$")
SHARD_RE = re.compile(r"^shard-(?P<writer>[A-Za-z0-9_-]+)-(?P<n>\d{6})\.tar$")


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
        h.update(name.encode("utf-8") + b"\0" + len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()


def fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def keys_sha256(keys: Iterable[str]) -> str:
    """sha256 of the sorted keys, each followed by a newline (UTF-8)."""
    return hashlib.sha256("".join(f"{k}\n" for k in sorted(keys)).encode()).hexdigest()


def write_manifest(
    out_dir: str | Path, doc: dict[str, Any], name: str = MANIFEST, mode: int = 0o644
) -> Path:
    """Writes ``doc`` as JSON atomically and durably (temp file, fsync, rename, fsync dir)."""
    out = Path(out_dir)
    tmp = out / (name + ".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
    with open(fd, "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=2, sort_keys=True)
        f.write("\n")
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, out / name)
    fsync_dir(out)
    return out / name


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


class Member(NamedTuple):
    """A regular file in a tar: its name, where its header starts, its data, and where the next
    header starts (``end``)."""

    name: str
    offset: int
    offset_data: int
    size: int
    end: int


_ZERO_BLOCK = tarfile.NUL * tarfile.BLOCKSIZE


def _padded(size: int) -> int:
    return -(-size // tarfile.BLOCKSIZE) * tarfile.BLOCKSIZE


class _NotPlainUstar(Exception):
    pass


def _parse_header(block: bytes) -> tuple[str, int]:
    """(name, size) of a plain USTAR regular-file header; ValueError if damaged."""
    stored = int(block[148:156].split(b"\0", 1)[0].strip() or b"-1", 8)
    # The header checksum is the byte sum with its own field read as spaces. Adler-32's low half
    # is (1 + byte sum) mod 65521, computed in C: comparing modulo 65521 is 5x faster than sum().
    byte_sum = stored + sum(block[148:156]) - 8 * 32
    if (1 + byte_sum) % 65521 != zlib.adler32(block) & 0xFFFF:
        raise ValueError("bad header checksum")
    if block[156:157] not in (b"0", b"\0") or block[124] & 0x80:
        raise _NotPlainUstar  # pax/GNU extension, link, directory or base-256 size
    name = block[:100].split(b"\0", 1)[0].decode("utf-8")
    prefix = block[345:500].split(b"\0", 1)[0].decode("utf-8")
    size = int(block[124:136].split(b"\0", 1)[0].strip() or b"0", 8)
    return (f"{prefix}/{name}" if prefix else name), size


def scan_members(path: str | Path) -> list[Member]:
    """Regular-file members of a tar, in order; stops quietly at a truncated or damaged tail
    (a shard being written, or cut by a crash)."""
    path = Path(path)
    members: list[Member] = []
    try:
        with open(path, "rb", buffering=0) as f:
            fd, length, offset = f.fileno(), os.fstat(f.fileno()).st_size, 0
            while offset + tarfile.BLOCKSIZE <= length:
                block = os.pread(fd, tarfile.BLOCKSIZE, offset)
                if block == _ZERO_BLOCK:
                    break
                name, size = _parse_header(block)
                end = offset + tarfile.BLOCKSIZE + _padded(size)
                if end > length:
                    break
                members.append(Member(name, offset, offset + tarfile.BLOCKSIZE, size, end))
                offset = end
    except _NotPlainUstar:
        return _scan_with_tarfile(path)
    except (ValueError, UnicodeDecodeError) as exc:
        log.warning("%s: stopped reading at a damaged header (%s)", path.name, exc)
    return members


def _scan_with_tarfile(path: Path) -> list[Member]:
    members: list[Member] = []
    try:
        with tarfile.open(path, "r:") as tar:
            for m in tar:
                if m.isfile():
                    end = m.offset_data + _padded(m.size)
                    members.append(Member(m.name, m.offset, m.offset_data, m.size, end))
    except (tarfile.TarError, OSError) as exc:
        log.warning("%s: stopped reading at a damaged tail (%s)", path.name, exc)
    return members


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


def read_shard(path: str | Path, on_sample: Callable[[], None] | None = None) -> ShardContents:
    """Reads a shard once, front to back, for its sha256 and every sample's digest (holding
    one sample's parts at a time); ``on_sample()`` is called after each sample."""
    path = Path(path)
    members = scan_members(path)
    whole = hashlib.sha256()
    samples: list[tuple[str, str]] = []
    with open(path, "rb") as f:

        def take(n: int) -> bytes:
            data = f.read(n)
            if len(data) != n:
                raise OSError(f"{path.name}: changed while it was read")
            whole.update(data)
            return data

        key: str | None = None
        parts: list[tuple[str, bytes]] = []
        pos = 0
        for m in members:
            if member_key(m.name) != key:
                if key is not None:
                    samples.append((key, sample_sha256(parts)))
                    if on_sample:
                        on_sample()
                key, parts = member_key(m.name), []
            take(m.offset_data - pos)  # the member's header
            parts.append((m.name[len(key) + 1 :], take(m.size)))
            take(m.end - m.offset_data - m.size)  # padding to the 512-byte block
            pos = m.end
        if key is not None:
            samples.append((key, sample_sha256(parts)))
            if on_sample:
                on_sample()
        while chunk := f.read(1 << 20):  # end-of-archive blocks, or whatever follows
            whole.update(chunk)
            pos += len(chunk)
    return ShardContents(whole.hexdigest(), pos, samples)


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
