"""What one writer keeps on disk: its shards, repaired on start (``journal.recover``), the
keys durable in them and in the whole directory, and each new sample written once
(deduplicated by key) and made durable in batches. The MQTT side of the writer
(``datagen/writer/dataset_writer.py``) decides what arrives and when to ack; this decides what is kept."""

from __future__ import annotations

import logging
from collections.abc import Iterable
from pathlib import Path

from datagen.index_set import KeySet
from datagen.sample import Sample
from datagen.shards import ShardInfo
from datagen.writer.journal import others_durable_keys, recover
from datagen.writer.shard_writer import ShardWriter

log = logging.getLogger("datagen.writer")


class DurableSamples:
    """Writer ``writer_id``'s samples in ``out_dir``: recovered when made, then kept.

    ``keys``: the samples in this writer's shards; ``seen``: those durable anywhere in the
    directory (found at start, or learnt from other writers' acks); ``changed``: the samples
    recovery removed because their bytes were not those journalled (to be made again)."""

    def __init__(self, out_dir: Path, writer_id: str, shard_size: int):
        self.out_dir, self.writer_id = out_dir, writer_id
        recovered = recover(out_dir, writer_id)
        self.shards: list[ShardInfo] = recovered.shards
        # about a bit per sample (datagen.index_set): a writer's memory stays flat over a build
        self.keys = KeySet(recovered.keys)
        self.seen = KeySet(recovered.keys)
        self.seen.update(recovered.other_keys)
        self.changed = recovered.changed
        self.duplicates = 0
        if self.seen:
            log.info(
                "resuming: %d samples in my %d shards, %d in the directory",
                len(self.keys),
                len(self.shards),
                len(self.seen),
            )
        self._shards = ShardWriter(out_dir, writer_id, shard_size, recovered.next_shard)

    def keep(self, sample: Sample) -> None:
        """Writes ``sample`` unless its key is durable in the directory already (then it is
        counted as a duplicate: acked again, not written again). Durable after ``flush``."""
        if sample.key in self.seen:
            self.duplicates += 1
            log.debug("duplicate %s: acking again, not rewriting", sample.key)
            return
        self._shards.write(sample)
        self.seen.add(sample.key)
        self.keys.add(sample.key)

    def flush(self) -> None:
        """Everything kept so far is on disk (fsynced) and journalled."""
        self._shards.flush_durable()

    def learn(self, keys: Iterable[str]) -> None:
        """Samples another writer made durable in the directory."""
        self.seen.update(keys)

    def everything(self) -> KeySet:
        """Every key durable in the directory now, which becomes what is ``seen``: a sample
        removed as changed on disk since may come again."""
        self.seen = KeySet(self.keys)
        self.seen.update(others_durable_keys(self.out_dir, self.writer_id))
        return self.seen

    def seal(self) -> list[ShardInfo]:
        """Closes the open shard: nothing more is written. Every shard of this writer."""
        self.shards += self._shards.close()
        return self.shards

    def close(self) -> None:
        self._shards.close()

    def abandon(self) -> None:
        """On a full disk: the open shard is left for recovery to cut back."""
        self._shards.abandon()
