"""``datagen.stream(DIR)``: an iterable dataset for training loops, split across DataLoader
workers and across nodes, with a shuffle buffer and decoding on demand.

Every epoch, the samples (in storage order: shard by shard) are cut into one contiguous block per
(node, worker) slot, so each sample is read exactly once per epoch whatever the number of
workers or nodes. With ``shuffle=True`` the shard order is permuted per epoch before the cut and
each slot's block goes through a shuffle buffer; the permutations come from (seed, epoch), so
every worker and node agrees on them without talking.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.utils.data import IterableDataset, get_worker_info

from datagen.dataset.loader import ShardDataset
from datagen.dataset.parts import decode_parts


def _node() -> tuple[int, int]:
    """(rank, world size): torch.distributed when initialised, else $RANK/$WORLD_SIZE, else (0, 1)."""
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        return torch.distributed.get_rank(), torch.distributed.get_world_size()
    return int(os.environ.get("RANK", 0)), int(os.environ.get("WORLD_SIZE", 1))


class StreamingDataset(IterableDataset):
    """Items as from ``datagen.load`` (plus ``key``); ``parts`` limits what is read and decoded
    (e.g. ``{"rgb.png", "json"}``), ``decode=False`` yields the stored bytes; ``verify=True``
    checks every sample against the manifest first (as ``datagen.load``)."""

    def __init__(
        self,
        root: str | Path,
        *,
        shuffle: bool = False,
        buffer_size: int = 256,
        seed: int = 0,
        parts: set[str] | None = None,
        decode: bool = True,
        rank: int | None = None,
        world_size: int | None = None,
        verify: bool = False,
    ):
        self.source = ShardDataset(root, verify)
        self.shuffle, self.buffer_size, self.seed = shuffle, max(1, buffer_size), seed
        self.parts, self.decode = parts, decode
        self.rank, self.world_size = rank, world_size
        self.epoch = 0
        first = [self.source.location(i) for i in range(len(self.source))]
        self._order = sorted(range(len(self.source)), key=first.__getitem__)  # storage order
        self._shard_of = [first[i][0] for i in range(len(self.source))]

    def set_epoch(self, epoch: int) -> None:
        """Call before each epoch (in the main process) to get a new shuffle."""
        self.epoch = epoch

    def __len__(self) -> int:
        """Samples per epoch over all slots."""
        return len(self.source)

    def slot(self) -> tuple[int, int]:
        """(this iterator's slot, number of slots) over nodes x DataLoader workers."""
        rank, world = _node()
        rank = self.rank if self.rank is not None else rank
        world = self.world_size if self.world_size is not None else world
        info = get_worker_info()
        worker, workers = (info.id, info.num_workers) if info else (0, 1)
        return rank * workers + worker, world * workers

    def epoch_order(self) -> list[int]:
        if not self.shuffle:
            return list(self._order)
        shards = sorted(set(self._shard_of))
        rank_of = dict(
            zip(
                np.random.default_rng([self.seed, self.epoch]).permutation(shards),
                range(len(shards)),
                strict=True,
            )
        )
        return sorted(
            self._order, key=lambda i: rank_of[self._shard_of[i]]
        )  # stable: in-shard order kept

    def __iter__(self) -> Iterator[dict[str, Any]]:
        slot, slots = self.slot()
        order = self.epoch_order()
        block = order[slot * len(order) // slots : (slot + 1) * len(order) // slots]
        if not self.shuffle:
            yield from map(self._item, block)
            return
        rng = np.random.default_rng([self.seed, self.epoch, slot])
        buffer: list[int] = []
        for index in block:
            buffer.append(index)
            if len(buffer) >= self.buffer_size:
                yield self._item(buffer.pop(int(rng.integers(len(buffer)))))
        rng.shuffle(buffer)
        yield from map(self._item, buffer)

    def _item(self, index: int) -> dict[str, Any]:
        raw = self.source.raw(index, self.parts)
        item: dict[str, Any] = decode_parts(raw) if self.decode else dict(raw)
        item["key"] = self.source.keys[index]
        return item


def stream(root: str | Path, **options: Any) -> StreamingDataset:
    return StreamingDataset(root, **options)
