"""Writing shards: ``ShardWriter`` rolls samples into shards and makes them durable;
``remove_keys`` rewrites a closed shard without some samples, atomically.

Members carry mtime 0, uid/gid 0, empty user/group names and mode 0o644, so the same samples
in the same order give byte-identical shards. Each shard's ``ShardInfo`` records every sample's
``sample_sha256``, computed from the parts as they are written; re-reading the shard
(``read_shard``) gives the same digests. Durability and crash recovery:
``datagen.sinks.journal``.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import tarfile
from pathlib import Path

from datagen.sample import Sample
from datagen.shards import (
    ShardInfo,
    fsync_dir,
    member_key,
    read_shard,
    sample_sha256,
    scan_members,
    shard_name,
    valid_writer_id,
)
from datagen.sinks.journal import journal_entry, journal_path


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
        self.digests: dict[str, str] = {}  # key -> sample_sha256

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
        self.digests[sample.key] = sample_sha256(sample.parts.items())

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
        sha256 = self.file.sha256.hexdigest()
        return ShardInfo(self.path.name, self.samples, sha256, size, self.digests)


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
        entry = journal_entry(name, offset, samples, closed)
        self._journal.write(json.dumps(entry) + "\n")
        self._journal.flush()
        os.fsync(self._journal.fileno())


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
    with open(path, "rb") as src, open(tmp, "wb") as dst:
        for m in kept:
            src.seek(m.offset)
            left = m.end - m.offset
            while left:
                chunk = src.read(min(left, 1 << 20))
                if not chunk:
                    raise OSError(f"{path.name}: shorter than its headers say")
                dst.write(chunk)
                left -= len(chunk)
        end = dst.tell() + 2 * tarfile.BLOCKSIZE
        dst.write(tarfile.NUL * (2 * tarfile.BLOCKSIZE + (-end) % tarfile.RECORDSIZE))
        dst.flush()
        os.fsync(dst.fileno())
    info = read_shard(tmp).info(path.name)  # read back: the digests are of what is on disk
    os.replace(tmp, path)
    fsync_dir(out)
    return info
