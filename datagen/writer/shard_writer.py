"""Writing shards: ``ShardWriter`` rolls samples into shards and makes them durable;
``remove_keys`` (``datagen.writer.shard_rewrite``) rewrites a closed shard without some samples,
atomically.

Members carry mtime 0, uid/gid 0, empty user/group names and mode 0o644, so the same samples
in the same order give byte-identical shards. Each shard's ``ShardInfo`` records every sample's
``sample_sha256``, computed from the parts as they are written; re-reading the shard
(``read_shard``) gives the same digests. Each journal line carries the digests of the samples it
makes durable, so a resumed build can tell a sample changed on disk since. Durability and crash
recovery: ``datagen.writer.journal``.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import tarfile
from dataclasses import replace
from pathlib import Path

from datagen.sample import Sample
from datagen.shards import ShardInfo, fsync_dir, sample_sha256, shard_name, valid_writer_id
from datagen.writer.journal import journal_entry, journalled_digests, open_journal
from datagen.writer.shard_rewrite import remove_keys as remove_keys  # where callers look for it
from datagen.writer.tar_end import zip_clear_padding


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
        self.tar = tarfile.TarFile(
            fileobj=self.file,  # type: ignore[arg-type]
            mode="w",
            format=tarfile.USTAR_FORMAT,
            # a part in one write and one hash update, not tarfile's 16 KiB at a time (0.7 ms
            # of the 5 ms a 1.3 MB sample took to keep)
            copybufsize=4 << 20,
        )
        self.samples = 0
        self.digests: dict[str, str] = {}  # key -> sample_sha256
        self.unjournalled: dict[str, str] = {}  # the digests no journal line carries yet

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
        digest = sample_sha256(sample.parts.items())
        self.digests[sample.key] = self.unjournalled[sample.key] = digest

    def sync(self) -> int:
        """Flushes and fsyncs; returns the durable length in bytes."""
        self.file.f.flush()
        os.fsync(self.file.f.fileno())
        return self.tar.offset

    def close(self) -> ShardInfo:
        self.tar.close()  # end-of-archive blocks and record padding
        self.file.f.flush()
        with open(self.path, "rb") as written:
            self.file.write(zip_clear_padding(written))  # never taken for a zip (tar_end)
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
        self._closed: list[ShardInfo] = []  # without their digests: those are journalled
        self._next = start_shard
        self._open: _OpenShard | None = None
        self._journal = open_journal(self.out_dir, writer_id)

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
            self._log(self._open, self._open.path.name, offset, closed=False)

    def close(self) -> list[ShardInfo]:
        """Closes the open shard; returns every shard this writer closed, with the digests of
        its samples read back from the journal."""
        if self._open is not None:
            self._close_shard()
        if not self._journal.closed:
            self._journal.close()
        return self.shards

    @property
    def shards(self) -> list[ShardInfo]:
        """Every shard this writer closed, with its samples' digests read from the journal."""
        if not self._closed:
            return []
        digests = journalled_digests(self.out_dir, self.writer_id)
        return [replace(info, sample_sha256=digests[info.name]) for info in self._closed]

    def abandon(self) -> None:
        """Closes the files without finishing the open shard (its disk is full): what the
        journal says is durable stays, and recovery cuts the rest."""
        for f in (self._open.file.f if self._open else None, self._journal):
            if f is not None:
                with contextlib.suppress(OSError):  # the buffered bytes find no room either
                    f.close()
        self._open = None

    def _close_shard(self) -> None:
        assert self._open is not None
        shard, self._open = self._open, None
        info = shard.close()
        self._log(shard, info.name, info.bytes, closed=True)
        # its digests are in the journal now: memory stays flat over a long build (``close``)
        self._closed.append(replace(info, sample_sha256={}))

    def _log(self, shard: _OpenShard, name: str, offset: int, closed: bool) -> None:
        entry = journal_entry(name, offset, shard.samples, closed, shard.unjournalled)
        self._journal.write(json.dumps(entry) + "\n")
        self._journal.flush()
        os.fsync(self._journal.fileno())
        shard.unjournalled = {}
