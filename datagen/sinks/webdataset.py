"""WebDataset tar shards: ``shard-{writer_id}-{n:06d}.tar`` with members ``{key}.{part}``.

Members carry mtime 0, uid/gid 0, empty user/group names and mode 0o644, so the same samples
in the same order give byte-identical shards.

Durability: ``flush_durable()`` fsyncs the open shard, then appends the durable end offset to a
journal (``.writer-{writer_id}.journal``, JSON lines) and fsyncs that. After a crash,
``recover()`` cuts each unfinished shard back to its last journalled offset, a sample
boundary, and terminates it as a valid tar: only samples that were made durable (and so
possibly acknowledged) survive, never half a sample.
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
import os
import re
import tarfile
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

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


def write_manifest(out_dir: str | Path, doc: dict[str, Any], name: str = MANIFEST) -> Path:
    """Writes ``doc`` as JSON atomically and durably (temp file, fsync, rename, fsync dir)."""
    out = Path(out_dir)
    tmp = out / (name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
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


def read_keys(path: Path) -> list[str]:
    """Sample keys in a tar, in order; stops quietly at a truncated tail."""
    keys: list[str] = []
    try:
        with tarfile.open(path, "r:") as tar:
            for member in tar:
                key = member_key(member.name)
                if not keys or keys[-1] != key:
                    keys.append(key)
    except (tarfile.TarError, OSError) as exc:
        log.warning("%s: stopped reading at a damaged tail (%s)", path.name, exc)
    return keys


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


def recover(out_dir: str | Path, writer_id: str) -> Recovered:
    """Repairs this writer's shards after a crash and collects every key in ``out_dir``."""
    out = Path(out_dir)
    result = Recovered()
    if not out.is_dir():
        return result
    journal: dict[str, dict] = {}
    jpath = journal_path(out, writer_id)
    if jpath.exists():
        for line in jpath.read_text(encoding="utf-8").splitlines():
            try:
                entry = json.loads(line)
                journal[entry["shard"]] = entry
            except (ValueError, KeyError, TypeError):
                log.warning("%s: skipping a damaged journal line", jpath.name)
    repaired: list[dict] = []
    for path in sorted(out.glob("shard-*.tar")):
        m = SHARD_RE.match(path.name)
        if m is None:
            continue
        if m["writer"] != writer_id:
            result.other_keys.update(read_keys(path))
            continue
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
        with open(jpath, "a", encoding="utf-8") as f:
            f.writelines(json.dumps(e) + "\n" for e in repaired)
            f.flush()
            os.fsync(f.fileno())
    fsync_dir(out)
    return result
