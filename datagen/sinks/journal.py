"""The writer's crash journal and the recovery it allows.

``ShardWriter.flush_durable()`` fsyncs the open shard, then appends the durable end offset to
the journal (``.writer-{writer_id}.journal``, JSON lines ``{"shard", "offset", "samples",
"closed"}``) and fsyncs that. After a crash, ``recover()`` cuts each unfinished shard back to
its last journalled offset, a sample boundary, and terminates it as a valid tar: only samples
that were made durable (and so possibly acknowledged) survive, never half a sample.
``durable_keys`` applies the same rule to another writer's shards while that writer is still
writing them.
"""

from __future__ import annotations

import json
import logging
import os
import tarfile
from dataclasses import dataclass, field
from pathlib import Path

from datagen.shards import (
    SHARD_RE,
    ShardInfo,
    fsync_dir,
    keys_of_members,
    read_keys,
    read_shard,
    scan_members,
    shards_by_writer,
)

log = logging.getLogger(__name__)


def journal_path(out_dir: Path, writer_id: str) -> Path:
    return Path(out_dir) / f".writer-{writer_id}.journal"


def journal_entry(shard: str, offset: int, samples: int, closed: bool) -> dict:
    """One journal line: ``shard`` is durable up to ``offset`` bytes (``samples`` samples);
    ``closed``: it is a finished tar."""
    return {"shard": shard, "offset": offset, "samples": samples, "closed": closed}


def append_journal(out_dir: str | Path, writer_id: str, entries: list[dict]) -> None:
    """Appends ``entries`` (``journal_entry``) and fsyncs."""
    with open(journal_path(Path(out_dir), writer_id), "a", encoding="utf-8") as f:
        f.writelines(json.dumps(e) + "\n" for e in entries)
        f.flush()
        os.fsync(f.fileno())


@dataclass
class Recovered:
    """What an out dir already holds, after repairs: this writer's shards and keys, and the
    keys in other writers' shards."""

    shards: list[ShardInfo] = field(default_factory=list)
    keys: set[str] = field(default_factory=set)
    other_keys: set[str] = field(default_factory=set)
    next_shard: int = 0


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
                keys.update(keys_of_members(scan_members(path), int(entry["offset"])))
            elif entry is not None or _is_terminated_tar(path):
                keys.update(read_keys(path))
        except (OSError, ValueError, TypeError):
            continue  # removed or rewritten meanwhile: not counted (the safe side)
    return keys


def others_durable_keys(out_dir: str | Path, writer_id: str) -> set[str]:
    """``durable_keys`` of every writer in ``out_dir`` but ``writer_id``."""
    keys: set[str] = set()
    for other, paths in shards_by_writer(out_dir).items():
        if other != writer_id:
            keys |= durable_keys(out_dir, other, paths)
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
    result.other_keys = others_durable_keys(out, writer_id)
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
        info = read_shard(path).info(path.name)  # the digests a writer computes as it writes
        if entry is not None and not entry.get("closed"):
            repaired.append(journal_entry(info.name, info.bytes, info.samples, closed=True))
        result.shards.append(info)
        result.keys.update(info.sample_sha256)
    if repaired:
        append_journal(out, writer_id, repaired)
    fsync_dir(out)
    return result
