"""The writer's crash journal and the recovery it allows.

``ShardWriter.flush_durable()`` fsyncs the open shard, then appends the durable end offset to
the journal (``.writer-{writer_id}.journal``, JSON lines ``{"shard", "offset", "samples",
"closed", "sample_sha256"}``) and fsyncs that; ``sample_sha256`` holds the digests
(``datagen.shards.sample_sha256``) of the samples that line makes durable. After a crash,
``recover()`` cuts each unfinished shard back to its last journalled offset, a sample boundary,
and terminates it as a valid tar: only samples that were made durable (and so possibly
acknowledged) survive, never half a sample. It then re-reads every sample and removes those
whose bytes are not the ones journalled when they were made durable (changed on disk since, or
with no digest journalled): they are made again from their (seed, index).
``durable_keys`` applies the same rule, but for the bytes, to another writer's shards while
that writer is still writing them.
"""

from __future__ import annotations

import json
import logging
import os
import tarfile
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from datagen.shard_members import scan_members
from datagen.shards import (
    SHARD_RE,
    ShardInfo,
    fsync_dir,
    keys_of_members,
    read_shard,
    shards_by_writer,
)
from datagen.writer.journal_lines import check_within_shards, journal_entries
from datagen.writer.shard_rewrite import remove_keys
from datagen.writer.tar_end import end_of_archive, zip_clear_padding

log = logging.getLogger(__name__)


def journal_path(out_dir: Path, writer_id: str) -> Path:
    return Path(out_dir) / f".writer-{writer_id}.journal"


def journal_entry(
    shard: str, offset: int, samples: int, closed: bool, digests: dict[str, str]
) -> dict:
    """One journal line: ``shard`` is durable up to ``offset`` bytes (``samples`` samples);
    ``closed``: it is a finished tar; ``digests``: key -> ``sample_sha256`` of the samples this
    line makes durable (all ``samples`` of them in a shard's first line, or after a rewrite)."""
    return {
        "shard": shard,
        "offset": offset,
        "samples": samples,
        "closed": closed,
        "sample_sha256": digests,
    }


def whole_shard_entry(info: ShardInfo) -> dict:
    """The journal line of a closed shard written anew (cut back, or rewritten without some
    samples): every sample's digest."""
    return journal_entry(info.name, info.bytes, info.samples, True, dict(info.sample_sha256))


def open_journal(out_dir: str | Path, writer_id: str) -> TextIO:
    """The journal, opened for appending; a line a crash or a full disk cut short is ended
    first, so that no new line continues it."""
    path = journal_path(Path(out_dir), writer_id)
    f = open(path, "a", encoding="utf-8")  # noqa: SIM115 - the caller closes it
    if f.tell() > 0:
        with open(path, "rb") as tail:
            tail.seek(-1, os.SEEK_END)
            if tail.read(1) != b"\n":
                f.write("\n")
    return f


def append_journal(out_dir: str | Path, writer_id: str, entries: list[dict]) -> None:
    """Appends ``entries`` (``journal_entry``) and fsyncs."""
    with open_journal(out_dir, writer_id) as f:
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
    changed: list[str] = field(default_factory=list)  # removed: not the bytes made durable


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
        f.write(end_of_archive(offset))
        f.write(zip_clear_padding(f))  # as ShardWriter ends a shard (datagen.writer.tar_end)
        f.flush()
        os.fsync(f.fileno())


def journalled_digests(out_dir: str | Path, writer_id: str) -> dict[str, dict[str, str]]:
    """Shard name -> key -> ``sample_sha256`` of every sample the journal of ``writer_id``
    holds (a writer keeps its closed shards' digests here, not in memory)."""
    journal = _read_journal(Path(out_dir), writer_id)
    return {name: entry["sample_sha256"] for name, entry in journal.items()}


def _read_journal(out: Path, writer_id: str, strict: bool = True) -> dict[str, dict]:
    """Last journal entry per shard, its ``sample_sha256`` holding every digest journalled for
    the shard. A line an interrupted append cut short is skipped; any other bad line raises
    ``JournalError`` naming the file and line, or is skipped too when not ``strict``
    (``journal_lines``)."""
    journal: dict[str, dict] = {}
    for entry in journal_entries(journal_path(out, writer_id), strict):
        journal[entry["shard"]] = _with_digests(entry, journal.get(entry["shard"]))
    return journal


def _with_digests(entry: dict, previous: dict | None) -> dict:
    """``entry`` with ``sample_sha256`` holding the digests journalled for its shard so far: a
    line listing all of the shard's samples starts afresh (a new shard, or a rewritten one)."""
    new = entry.get("sample_sha256")
    new = new if isinstance(new, dict) else {}  # a line written before digests were journalled
    if previous is None or len(new) >= entry["samples"]:
        return entry | {"sample_sha256": new}
    return entry | {"sample_sha256": previous["sample_sha256"] | new}


def durable_keys(out_dir: str | Path, writer_id: str, shards: list[Path] | None = None) -> set[str]:
    """Keys in ``writer_id``'s shards that its own recovery would keep, read without touching
    its files (it may be writing them): a closed shard's keys, an open shard's keys up to its
    journalled durable offset, each with a journalled digest (its bytes are not re-read)."""
    out = Path(out_dir)
    if shards is None:
        shards = shards_by_writer(out).get(writer_id, [])
    journal = _read_journal(out, writer_id, strict=False)  # another writer's: the safe side
    keys: set[str] = set()
    for path in shards:
        entry = journal.get(path.name)
        if entry is None:
            continue  # nothing journalled: its recovery removes it
        try:
            durable = None if entry.get("closed") else int(entry["offset"])
            found = keys_of_members(scan_members(path), durable)
        except (OSError, ValueError, TypeError):
            continue  # removed or rewritten meanwhile: not counted (the safe side)
        keys.update(k for k in found if k in entry["sample_sha256"])
    return keys


def others_durable_keys(out_dir: str | Path, writer_id: str) -> set[str]:
    """``durable_keys`` of every writer in ``out_dir`` but ``writer_id``."""
    keys: set[str] = set()
    for other, paths in shards_by_writer(out_dir).items():
        if other != writer_id:
            keys |= durable_keys(out_dir, other, paths)
    return keys


def recover(out_dir: str | Path, writer_id: str) -> Recovered:
    """Repairs this writer's shards after a crash, removes the samples whose bytes are not
    those journalled (``Recovered.changed``), and collects every durable key in ``out_dir``
    (other writers' keys as ``durable_keys`` sees them)."""
    out = Path(out_dir)
    result = Recovered()
    if not out.is_dir():
        return result
    journal = _read_journal(out, writer_id)
    own = shards_by_writer(out).get(writer_id, [])
    check_within_shards(journal, own, journal_path(out, writer_id))  # before any repair
    repaired: list[dict] = []
    result.other_keys = others_durable_keys(out, writer_id)
    for path in own:
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
        info = _keep_journalled(path, entry, result.changed)
        if info is None:
            continue
        if entry is None or not entry.get("closed") or info.samples != entry["samples"]:
            repaired.append(whole_shard_entry(info))
        result.shards.append(info)
        result.keys.update(info.sample_sha256)
    if repaired:
        append_journal(out, writer_id, repaired)
    fsync_dir(out)
    return result


def _keep_journalled(path: Path, entry: dict | None, changed: list[str]) -> ShardInfo | None:
    """Re-reads the shard ``path`` and rewrites it without the samples whose digest is not the
    one journalled (``entry``), or that it holds twice; their keys go to ``changed``. Returns
    what is left (None: nothing, and the file is removed)."""
    contents = read_shard(path)
    journalled = entry["sample_sha256"] if entry is not None else {}
    copies = Counter(key for key, _ in contents.samples)
    bad = sorted(
        {key for key, digest in contents.samples if journalled.get(key) != digest}
        | {key for key, n in copies.items() if n > 1}
    )
    if not bad:
        return contents.info(path.name)
    log.warning(
        "%s: %d samples are not the bytes journalled when they were made durable (changed on "
        "disk since, or no digest journalled): %s; removing them: they are made again",
        path.name,
        len(bad),
        ", ".join(bad[:10]) + (" ..." if len(bad) > 10 else ""),
    )
    changed.extend(bad)
    return remove_keys(path, set(bad))
