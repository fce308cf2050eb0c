"""A finished build found in ``--out`` is checked before it is taken as done: its shards are read
once, front to back, against its manifest (``datagen.dataset.integrity``: a megabyte at a time,
at disk speed). What differs is made again by ``--resume`` through the interrupted build's own
path: ``reopen`` gives each writer the journal it had before the finalize round (a line per
shard, with the digests the manifest lists) and removes the manifest, so the writers' recovery
removes the samples whose bytes are not those (``datagen.writer.journal.recover``), the build
makes them again from their (seed, index), and the finalize round writes a new manifest.
"""

from __future__ import annotations

import os
from pathlib import Path

from datagen.config import BuildConfig
from datagen.dataset.integrity import verify_dataset
from datagen.dataset.manifest import DatasetError
from datagen.records import ShardRecord
from datagen.shards import MANIFEST, SHARD_RE, fsync_dir
from datagen.writer.journal import append_journal, journal_entry

SHOWN = 3  # problems named in a message; verify names them all


def differences(out_dir: Path, config: BuildConfig) -> list[str]:
    """What in ``out_dir``'s shards differs from its manifest (nothing: the build is intact)."""
    try:
        report = verify_dataset(out_dir, expected=config.num_samples)
    except DatasetError as exc:
        return [str(exc)]
    if report.problems and not report.per_sample:
        report.problems.append(
            "its manifest predates per-sample digests, so which samples differ is not known"
        )
    return report.problems


def remakeable(problems: list[str]) -> bool:
    """Whether ``--resume`` can make again what ``differences`` found: it knows each sample's
    digest."""
    return not any("predates per-sample digests" in p for p in problems)


def described(out_dir: Path, problems: list[str]) -> str:
    """One line: ``DIR holds this build, but its shards differ from its manifest: ...``."""
    shown = "; ".join(problems[:SHOWN])
    more = f"; and {len(problems) - SHOWN} more" if len(problems) > SHOWN else ""
    return (
        f"{out_dir} holds this build, but its shards differ from its manifest: {shown}{more} "
        f"(all of it: datagen verify {out_dir})"
    )


def reopen(out_dir: Path, shards: list[ShardRecord]) -> None:
    """Turns the finished build in ``out_dir`` back into an interrupted one: each listed shard
    that is there at its listed size is journalled for its writer as closed, with the digests
    its manifest ``shards`` records list (one that is not is journalled for nobody: recovery
    removes it, and its samples are made again); then the manifest is removed."""
    lines: dict[str, list[dict]] = {}
    for record in shards:
        match = SHARD_RE.match(record["name"])
        path = out_dir / record["name"]
        if match is None or not path.is_file() or path.stat().st_size != record.get("bytes"):
            continue
        digests = dict(record.get("sample_sha256", {}))
        entry = journal_entry(record["name"], record["bytes"], len(digests), True, digests)
        lines.setdefault(match["writer"], []).append(entry)
    for writer_id, entries in lines.items():
        append_journal(out_dir, writer_id, entries)
    os.unlink(out_dir / MANIFEST)
    fsync_dir(out_dir)
