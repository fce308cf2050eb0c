"""The finalize round, as one writer runs it: the writers agree over MQTT statuses.

A ``finalize`` control command (``{"cmd": "finalize", "id", "writers", "expected", "manifest",
"timeout_s"}``, docs/wire-format.md) lists the writers that finish the build together. Each
listed writer closes its open shard (``DatasetWriter``), then ``run_round`` publishes
``sealed`` and:

1. waits until every listed writer is ``sealed`` (nothing more is written anywhere), drops its
   copies of keys that a smaller writer id also holds, writes its part file and publishes
   ``prepared``;
2. the leader (the smallest listed id) waits for every ``prepared``, checks the directory
   (``combine``) and writes ``manifest.json``; every other writer waits for the leader's
   ``finalized``;
3. removes its journal and part file and publishes ``finalized``.

Another listed writer's ``error`` status of this round, the command's ``timeout_s`` or a failed
check (``FinalizeError``) ends the round with the status ``error`` and no manifest. Statuses:
``datagen.writer.status``; the file side (part files, dropping copies, combining):
``datagen.writer.finalize``.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from datagen.index_set import KeySet
from datagen.shards import DATASET_FORMAT, ShardInfo, valid_writer_id, write_json_durably
from datagen.transport.topics import DEFAULT_FINALIZE_TIMEOUT_S
from datagen.writer.finalize import (
    FinalizeError,
    combine,
    drop_copies_held_by_smaller,
    part_path,
    write_part,
)
from datagen.writer.journal import journal_path
from datagen.writer.status import WriterStatus

log = logging.getLogger("datagen.writer")  # the writer process's log


def finalize_args(cmd: dict[str, Any], writer_id: str) -> dict[str, Any] | None:
    """The checked arguments of a finalize command; None if this writer is not listed."""
    writers = cmd.get("writers", [writer_id])
    if (
        not isinstance(writers, list)
        or not writers
        or not all(isinstance(w, str) and valid_writer_id(w) for w in writers)
    ):
        raise ValueError(f"finalize 'writers' must be a list of writer ids, got {writers!r:.200}")
    expected, manifest = cmd.get("expected"), cmd.get("manifest", {})
    if (
        not isinstance(expected, int)
        or isinstance(expected, bool)
        or not isinstance(manifest, dict)
    ):
        raise ValueError("finalize needs an integer 'expected' and an object 'manifest'")
    timeout_s = cmd.get("timeout_s", DEFAULT_FINALIZE_TIMEOUT_S)
    if not isinstance(timeout_s, int | float) or timeout_s <= 0:
        raise ValueError(f"finalize 'timeout_s' must be a positive number, got {timeout_s!r}")
    if writer_id not in writers:
        return None
    return {
        "id": str(cmd.get("id", "")),
        "writers": sorted(set(writers)),
        "expected": expected,
        "manifest": manifest,
        "timeout_s": float(timeout_s),
    }


def run_round(
    args: dict[str, Any],
    deadline: float,
    *,
    out_dir: Path,
    build_id: str,
    shards: list[ShardInfo],
    keys: KeySet,
    counters: dict[str, int],
    status: WriterStatus,
) -> tuple[list[ShardInfo], KeySet] | None:
    """The round of the writer of ``status`` that has sealed its closed ``shards`` holding
    ``keys`` (``args``: ``finalize_args``; ``counters``: extra fields of its part file).
    Returns its shards and keys after dropping copies; None if the round was refused (then its
    status is ``error``)."""
    writer_id, round_id, writers = status.writer_id, args["id"], args["writers"]
    leader = writers[0]
    status.publish("sealed", round=round_id, samples=len(keys))
    try:
        status.wait(writers, round_id, {"sealed", "prepared", "finalized"}, deadline)
        shards, removed = drop_copies_held_by_smaller(out_dir, writer_id, shards)
        for key in removed:
            keys.discard(key)
        write_part(
            out_dir,
            writer_id,
            round_id,
            build_id=build_id,
            samples=len(keys),
            shards=[s.to_json() for s in shards],
            **counters,
            copies_removed=len(removed),
        )
        status.publish("prepared", round=round_id, samples=len(keys))
        if writer_id == leader:
            status.wait(writers, round_id, {"prepared", "finalized"}, deadline)
            doc = combine(out_dir, writers, round_id, args["expected"])
            manifest = {**args["manifest"], "build_id": build_id, "format": "webdataset"}
            manifest["dataset_format"] = DATASET_FORMAT  # what this writer wrote
            write_json_durably(out_dir, {**manifest, **doc})
            total = doc["samples"]
        else:
            total = status.wait([leader], round_id, {"finalized"}, deadline)[leader]["samples"]
    except FinalizeError as exc:
        log.error("finalize refused: %s", exc.reason)
        status.publish("error", round=round_id, reason=exc.reason, **exc.fields)
        return None
    journal_path(out_dir, writer_id).unlink(missing_ok=True)
    part_path(out_dir, writer_id).unlink(missing_ok=True)
    status.publish("finalized", round=round_id, samples=total, own=len(keys))
    log.info("finalized: %d samples (%d in my %d shards)", total, len(keys), len(shards))
    return shards, keys
