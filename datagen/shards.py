"""WebDataset tar shards: ``shard-{writer_id}-{n:06d}.tar`` with members ``{key}.{part}``.

Members carry mtime 0, uid/gid 0, empty user/group names and mode 0o644, so the same samples
in the same order give byte-identical shards.

Durability: ``flush_durable()`` fsyncs the open shard, then appends the durable end offset to a
journal (``.writer-{writer_id}.journal``, JSON lines) and fsyncs that. After a crash,
``recover()`` cuts each unfinished shard back to its last journalled offset, a sample
boundary, and terminates it as a valid tar: only samples that were made durable (and so
possibly acknowledged) survive, never half a sample. ``durable_keys`` applies the same rule to
another writer's shards while that writer is still writing them.

Several writers may share one directory (distinct writer ids); ``WriterLock`` keeps two
processes with the same id off the same directory. ``scan_members`` reads tar headers directly
(about 15x faster than ``tarfile`` on 10^5 samples), and ``remove_keys`` rewrites a shard
without some samples, atomically.
"""

from __future__ import annotations

import errno
import fcntl
import hashlib
import io
import json
import logging
import os
import re
import tarfile
import zlib
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from datagen.sample import Sample

log = logging.getLogger(__name__)

MANIFEST = "manifest.json"
_WRITER_ID = re.compile(r"^[A-Za-z0-9_-]{1,32}$")
SHARD_RE = re.compile(r"^shard-(?P<writer>[A-Za-z0-9_-]+)-(?P<n>\d{6})\.tar$")


def valid_writer_id(writer_id: str) -> bool:
    return bool(_WRITER_ID.match(writer_id))


def shard_name(writer_id: str, n: int) -> str:
    return f"shard-{writer_id}-{n:06d}.tar"


def journal_path(out_dir: Path, writer_id: str) -> Path:
    return Path(out_dir) / f".writer-{writer_id}.journal"


def member_key(member_name: str) -> str:
    """``000000042.rgb.png`` -> ``000000042`` (WebDataset splits at the first dot)."""
    return member_name.split(".", 1)[0]


@dataclass
class ShardInfo:
    name: str
    samples: int
    sha256: str
    bytes: int

    def to_json(self) -> dict:
        return asdict(self)


@dataclass
class Recovered:
    """What an out dir already holds, after repairs: this writer's shards and keys, and the
    keys in other writers' shards."""

    shards: list[ShardInfo] = field(default_factory=list)
    keys: set[str] = field(default_factory=set)
    other_keys: set[str] = field(default_factory=set)
    next_shard: int = 0


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


class _HashingFile:
    """Write-only file wrapper that hashes what goes through (tarfile writes sequentially)."""

    def __init__(self, path: Path):
        self.f = open(path, "xb")  # noqa: SIM115 - closed by _OpenShard.close
        self.sha256 = hashlib.sha256()

    def write(self, data: bytes) -> int:
        self.sha256.update(data)
        return self.f.write(data)

    def tell(self) -> int:
        return self.f.tell()


class _OpenShard:
    def __init__(self, path: Path):
        self.path = path
        self.file = _HashingFile(path)
        self.tar = tarfile.TarFile(fileobj=self.file, mode="w", format=tarfile.USTAR_FORMAT)  # type: ignore[arg-type]
        self.samples = 0

    def add(self, sample: Sample) -> None:
        for part, data in sample.parts.items():
            info = tarfile.TarInfo(f"{sample.key}.{part}")
            info.size = len(data)
            info.mtime = 0
            info.mode = 0o644
            info.uid = info.gid = 0
            info.uname = info.gname = ""
            self.tar.addfile(info, io.BytesIO(data))
        self.samples += 1

    def sync(self) -> int:
        """Flushes and fsyncs; returns the durable length in bytes."""
        self.file.f.flush()
        os.fsync(self.file.f.fileno())
        return self.tar.offset

    def close(self) -> ShardInfo:
        self.tar.close()  # end-of-archive blocks and record padding
        self.sync()
        size = self.file.f.tell()
        self.file.f.close()
        return ShardInfo(self.path.name, self.samples, self.file.sha256.hexdigest(), size)


class ShardWriter:
    """Writes samples into rolling shards of at most ``max_count`` samples each."""

    def __init__(
        self, out_dir: str | Path, writer_id: str, max_count: int = 1000, start_shard: int = 0
    ):
        if not valid_writer_id(writer_id):
            raise ValueError(f"invalid writer id {writer_id!r}: use 1-32 of [A-Za-z0-9_-]")
        if max_count < 1:
            raise ValueError("max_count must be >= 1")
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.writer_id = writer_id
        self.max_count = max_count
        self.shards: list[ShardInfo] = []
        self._next = start_shard
        self._open: _OpenShard | None = None
        self._journal = open(journal_path(self.out_dir, writer_id), "a", encoding="utf-8")  # noqa: SIM115

    def __enter__(self) -> ShardWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def write(self, sample: Sample) -> None:
        if self._open is not None and self._open.samples >= self.max_count:
            self._close_shard()
        if self._open is None:
            self._open = _OpenShard(self.out_dir / shard_name(self.writer_id, self._next))
            self._next += 1
            fsync_dir(self.out_dir)
        self._open.add(sample)

    def flush_durable(self) -> None:
        """Everything written so far survives a crash once this returns."""
        if self._open is not None:
            offset = self._open.sync()
            self._log(self._open.path.name, offset, self._open.samples, closed=False)

    def close(self) -> list[ShardInfo]:
        """Closes the open shard; returns every shard this writer closed."""
        if self._open is not None:
            self._close_shard()
        if not self._journal.closed:
            self._journal.close()
        return list(self.shards)

    def _close_shard(self) -> None:
        assert self._open is not None
        info = self._open.close()
        self._open = None
        self._log(info.name, info.bytes, info.samples, closed=True)
        self.shards.append(info)

    def _log(self, name: str, offset: int, samples: int, closed: bool) -> None:
        entry = {"shard": name, "offset": offset, "samples": samples, "closed": closed}
        self._journal.write(json.dumps(entry) + "\n")
        self._journal.flush()
        os.fsync(self._journal.fileno())


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


def _keys_of(members: list[Member], durable_bytes: int | None = None) -> list[str]:
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


def read_keys(path: Path) -> list[str]:
    """Sample keys in a tar, in order; stops quietly at a truncated tail."""
    return _keys_of(scan_members(path))


def _is_terminated_tar(path: Path) -> bool:
    size = path.stat().st_size
    if size == 0 or size % tarfile.RECORDSIZE:
        return False
    with open(path, "rb") as f:
        f.seek(size - 2 * tarfile.BLOCKSIZE)
        return f.read() == tarfile.NUL * (2 * tarfile.BLOCKSIZE)


def _terminate(path: Path, offset: int) -> None:
    """Cuts ``path`` to ``offset`` and appends the end-of-archive as ``TarFile.close`` would."""
    with open(path, "r+b") as f:
        f.truncate(offset)
        f.seek(offset)
        end = offset + 2 * tarfile.BLOCKSIZE
        pad = (-end) % tarfile.RECORDSIZE
        f.write(tarfile.NUL * (2 * tarfile.BLOCKSIZE + pad))
        f.flush()
        os.fsync(f.fileno())


def _read_journal(out: Path, writer_id: str) -> dict[str, dict]:
    """Last journal entry per shard (a damaged or half-written line is skipped)."""
    journal: dict[str, dict] = {}
    jpath = journal_path(out, writer_id)
    try:
        text = jpath.read_text(encoding="utf-8")
    except FileNotFoundError:
        return journal
    for line in text.splitlines():
        try:
            entry = json.loads(line)
            journal[entry["shard"]] = entry
        except (ValueError, KeyError, TypeError):
            log.debug("%s: skipping a damaged journal line", jpath.name)
    return journal


def shards_by_writer(out_dir: str | Path) -> dict[str, list[Path]]:
    """Shard files in ``out_dir``, grouped by writer id, each list sorted by name."""
    found: dict[str, list[Path]] = {}
    for path in sorted(Path(out_dir).glob("shard-*.tar")):
        m = SHARD_RE.match(path.name)
        if m is not None:
            found.setdefault(m["writer"], []).append(path)
    return found


def durable_keys(out_dir: str | Path, writer_id: str, shards: list[Path] | None = None) -> set[str]:
    """Keys in ``writer_id``'s shards that its own recovery would keep, read without touching
    its files (it may be writing them): a closed shard's keys, an open shard's keys up to its
    journalled durable offset, a journal-less shard's keys if it is a terminated tar."""
    out = Path(out_dir)
    if shards is None:
        shards = shards_by_writer(out).get(writer_id, [])
    journal = _read_journal(out, writer_id)
    keys: set[str] = set()
    for path in shards:
        entry = journal.get(path.name)
        try:
            if entry is not None and not entry.get("closed"):
                keys.update(_keys_of(scan_members(path), int(entry["offset"])))
            elif entry is not None or _is_terminated_tar(path):
                keys.update(read_keys(path))
        except (OSError, ValueError, TypeError):
            continue  # removed or rewritten meanwhile: not counted (the safe side)
    return keys


def recover(out_dir: str | Path, writer_id: str) -> Recovered:
    """Repairs this writer's shards after a crash and collects every durable key in
    ``out_dir`` (other writers' keys as ``durable_keys`` sees them)."""
    out = Path(out_dir)
    result = Recovered()
    if not out.is_dir():
        return result
    journal = _read_journal(out, writer_id)
    repaired: list[dict] = []
    for other, paths in shards_by_writer(out).items():
        if other != writer_id:
            result.other_keys.update(durable_keys(out, other, paths))
    for path in shards_by_writer(out).get(writer_id, []):
        m = SHARD_RE.match(path.name)
        assert m is not None
        result.next_shard = max(result.next_shard, int(m["n"]) + 1)
        entry = journal.get(path.name)
        if entry is not None and not entry.get("closed"):
            log.warning(
                "%s: unfinished; cutting back to its durable %d bytes", path.name, entry["offset"]
            )
            _terminate(path, entry["offset"])
        elif entry is None and not _is_terminated_tar(path):
            log.warning("%s: nothing in it was made durable; removing it", path.name)
            path.unlink()
            continue
        keys = read_keys(path)
        info = ShardInfo(path.name, len(keys), file_sha256(path), path.stat().st_size)
        if entry is not None and not entry.get("closed"):
            repaired.append(
                {"shard": info.name, "offset": info.bytes, "samples": info.samples, "closed": True}
            )
        result.shards.append(info)
        result.keys.update(keys)
    if repaired:
        append_journal(out, writer_id, repaired)
    fsync_dir(out)
    return result


def append_journal(out_dir: str | Path, writer_id: str, entries: list[dict]) -> None:
    with open(journal_path(Path(out_dir), writer_id), "a", encoding="utf-8") as f:
        f.writelines(json.dumps(e) + "\n" for e in entries)
        f.flush()
        os.fsync(f.fileno())


def remove_keys(path: Path, keys: set[str]) -> ShardInfo | None:
    """Rewrites the closed shard ``path`` without the samples in ``keys`` (new tar next to it,
    fsync, rename over it, fsync the dir); deletes it when nothing is left (returns None)."""
    members = scan_members(path)
    kept = [m for m in members if member_key(m.name) not in keys]
    out = path.parent
    if not kept:
        path.unlink()
        fsync_dir(out)
        return None
    tmp = out / f".{path.name}.rewrite"
    sha = hashlib.sha256()
    samples = len(set(_keys_of(kept)))
    with open(path, "rb") as src, open(tmp, "wb") as dst:
        for m in kept:
            src.seek(m.offset)
            left = m.end - m.offset
            while left:
                chunk = src.read(min(left, 1 << 20))
                if not chunk:
                    raise OSError(f"{path.name}: shorter than its headers say")
                sha.update(chunk)
                dst.write(chunk)
                left -= len(chunk)
        end = dst.tell() + 2 * tarfile.BLOCKSIZE
        tail = tarfile.NUL * (2 * tarfile.BLOCKSIZE + (-end) % tarfile.RECORDSIZE)
        sha.update(tail)
        dst.write(tail)
        dst.flush()
        os.fsync(dst.fileno())
        size = dst.tell()
    os.replace(tmp, path)
    fsync_dir(out)
    return ShardInfo(path.name, samples, sha.hexdigest(), size)


class WriterLocked(RuntimeError):
    """Another process already runs this writer id on this directory."""


class WriterLock:
    """``flock`` on ``.writer-{id}.lock`` in the out dir, held while the writer runs (also works
    across machines on NFSv4, where Linux maps ``flock`` to NFS byte-range locks)."""

    def __init__(self, out_dir: str | Path, writer_id: str):
        self.path = Path(out_dir) / f".writer-{writer_id}.lock"
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "?"
            os.close(fd)
            if exc.errno not in (errno.EAGAIN, errno.EACCES):
                raise
            raise WriterLocked(
                f"writer {writer_id!r} is already running on {Path(out_dir)} ({holder} holds "
                f"{self.path.name}); give each writer its own --writer-id"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} on {os.uname().nodename}\n".encode(), 0)
        self._fd: int | None = fd

    def __enter__(self) -> WriterLock:
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def release(self, remove: bool = False) -> None:
        """Unlocks; ``remove`` also deletes the file (after a finished build)."""
        if self._fd is None:
            return
        if remove:
            self.path.unlink(missing_ok=True)
        os.close(self._fd)
        self._fd = None
