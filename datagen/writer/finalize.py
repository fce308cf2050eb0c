"""The file side of finalizing a build written by several writers into one directory.

Each writer, once every listed writer has stopped writing (``sealed``):

1. ``drop_copies_held_by_smaller``: a key held by several writers stays only with the writer
   whose id is smallest (string order); the others rewrite the affected shards without it.
   The smallest holder never drops its copy, so the outcome does not depend on timing.
2. ``write_part``: ``writer-<id>.json`` lists its shards and counters.

The leader (the smallest listed id) then runs ``combine``: every shard in the directory must
belong to a listed writer's part file with a digest for each of its samples, be the bytes its
writer reported (re-read: every sample's digest, the shard's sha256), no key may be in two
shards, and the keys must number exactly ``expected``; it returns what ``manifest.json`` adds to
the coordinator's manifest (the shards' records carry the per-sample digests). So a manifest is
never written over a sample changed on disk: the build fails instead, and ``--resume`` makes
that sample again.
Who waits for whom (the round over MQTT statuses): ``datagen.writer.finalize_round``.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from datagen.safe_json import loads_bounded
from datagen.shards import (
    ShardInfo,
    keys_sha256,
    read_keys,
    read_shard,
    shards_by_writer,
    write_json_durably,
)
from datagen.writer.journal import append_journal, whole_shard_entry
from datagen.writer.shard_rewrite import remove_keys

log = logging.getLogger(__name__)

PART_FORMAT = "datagen.writer-part/1"


class FinalizeError(RuntimeError):
    """Finalizing cannot produce a correct manifest; ``fields`` go into the error status."""

    def __init__(self, reason: str, **fields: Any):
        super().__init__(reason)
        self.reason = reason
        self.fields = fields


def part_path(out_dir: str | Path, writer_id: str) -> Path:
    return Path(out_dir) / f"writer-{writer_id}.json"


def drop_copies_held_by_smaller(
    out_dir: str | Path, writer_id: str, shards: list[ShardInfo]
) -> tuple[list[ShardInfo], set[str]]:
    """Removes from this writer's (closed) ``shards`` every key that a writer with a smaller id
    also holds; returns the shards left and the keys removed."""
    out = Path(out_dir)
    smaller: set[str] = set()
    for other, paths in shards_by_writer(out).items():
        if other < writer_id:
            for path in paths:
                smaller.update(read_keys(path))
    if not smaller:
        return shards, set()
    kept: list[ShardInfo] = []
    removed: set[str] = set()
    journal: list[dict] = []
    for info in shards:
        path = out / info.name
        drop = set(read_keys(path)) & smaller
        if not drop:
            kept.append(info)
            continue
        log.info("%s: removing %d samples a smaller writer id also holds", info.name, len(drop))
        new = remove_keys(path, drop)
        removed |= drop
        if new is not None:
            kept.append(new)
            journal.append(whole_shard_entry(new))
    if journal:
        append_journal(out, writer_id, journal)
    return kept, removed


def write_part(out_dir: str | Path, writer_id: str, round_id: str, **fields: Any) -> Path:
    doc = {"format": PART_FORMAT, "writer": writer_id, "round": round_id, **fields}
    return write_json_durably(out_dir, doc, name=part_path(out_dir, writer_id).name)


def read_part(out_dir: str | Path, writer_id: str, round_id: str) -> dict[str, Any]:
    path = part_path(out_dir, writer_id)
    try:
        doc = loads_bounded(path.read_bytes(), what=str(path))
    except (OSError, ValueError) as exc:  # JsonInputError is a ValueError
        raise FinalizeError(f"writer {writer_id!r}: cannot read {path.name}: {exc}") from None
    if not isinstance(doc, dict) or doc.get("round") != round_id:
        raise FinalizeError(f"writer {writer_id!r}: {path.name} is from another finalize")
    return doc


def combine(
    out_dir: str | Path, writers: list[str], round_id: str, expected: int
) -> dict[str, Any]:
    """Checks the directory against the writers' part files; returns the manifest fields."""
    out = Path(out_dir)
    parts = {w: read_part(out, w, round_id) for w in writers}
    listed = {s["name"]: s for p in parts.values() for s in p["shards"]}
    on_disk = {p.name for paths in shards_by_writer(out).values() for p in paths}
    if on_disk - listed.keys():
        stray = sorted(on_disk - listed.keys())
        raise FinalizeError(
            f"shards of writers not in the finalize list {writers}: {', '.join(stray[:10])}; "
            "restart those writers and list them, or move their shards away"
        )
    if listed.keys() - on_disk:
        raise FinalizeError(f"shards missing from {out}: {sorted(listed.keys() - on_disk)[:10]}")
    owner: dict[str, str] = {}
    for name in sorted(listed):
        path = out / name
        if path.stat().st_size != listed[name]["bytes"]:
            raise FinalizeError(f"{name} changed after its writer reported it")
        keys = _check_bytes(path, listed[name])
        for key in keys:
            if key in owner:
                raise FinalizeError(f"sample {key} is in both {owner[key]} and {name}")
            owner[key] = name
    if len(owner) != expected:
        raise FinalizeError(
            f"expected {expected} samples, have {len(owner)}", samples=len(owner), expected=expected
        )
    return {
        "samples": len(owner),
        "shards": [listed[name] for name in sorted(listed)],
        "keys_sha256": keys_sha256(owner),
        "writers": sorted(writers),
        "rejected_messages": sum(p.get("rejected_messages", 0) for p in parts.values()),
        "rejected_control_messages": sum(
            p.get("rejected_control_messages", 0) for p in parts.values()
        ),
        "duplicate_messages": sum(p.get("duplicate_messages", 0) for p in parts.values()),
        "duplicate_copies_removed": sum(p.get("copies_removed", 0) for p in parts.values()),
    }


def _check_bytes(path: Path, record: dict[str, Any]) -> list[str]:
    """The keys of the shard ``path``, re-read and checked against its writer's ``record``:
    its samples, each sample's digest and the shard's sha256."""
    name = path.name
    contents = read_shard(path)
    if len(contents.samples) != record["samples"]:
        raise FinalizeError(
            f"{name}: {len(contents.samples)} samples, its writer reported {record['samples']}"
        )
    digests = record.get("sample_sha256", {})
    if {key for key, _ in contents.samples} != set(digests):
        raise FinalizeError(f"{name}: its writer's sample digests do not match its samples")
    changed = sorted(key for key, digest in contents.samples if digests[key] != digest)
    if changed or contents.sha256 != record["sha256"]:
        shown = f" (samples {', '.join(changed[:10])})" if changed else ""
        raise FinalizeError(
            f"{path}: changed on disk after its writer made it durable{shown}; no manifest is "
            f"written: resume the build to make those samples again"
        )
    return [key for key, _ in contents.samples]
