"""Batches of dataset items for a torch DataLoader: :func:`collate` (``datagen.collate``, also
``datagen.dataset.loader.collate``)."""

from __future__ import annotations

from typing import Any

import numpy as np


def collate(items: list[dict[str, Any]]) -> dict[str, Any]:
    """``collate_fn`` for a torch DataLoader with ``batch_size > 1`` over ``load``, ``load_frames``
    or ``stream``: one dict with every key of the items. The arrays under a key, if all of one
    shape and dtype, become one tensor with the batch first (rgb (B, H, W, 3) uint8, depth
    (B, H, W), ...); every other value (``key`` strings, ``meta`` dicts, a navigation episode's
    ``frames``, bytes, numbers) stays a list with one entry per item, arrays of differing shapes a
    list of tensors, and a key an item lacks is None there.

    uint16 arrays (depth in millimetres, instance ids) become **int32** tensors: torch 2.13 has a
    uint16 dtype, but most operations on it (addition, max, ...) are not implemented; int32 holds
    every uint16 value exactly."""
    import torch

    def tensor(array: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(array.astype(np.int32) if array.dtype == np.uint16 else array)

    batch: dict[str, Any] = {}
    for name in dict.fromkeys(name for item in items for name in item):
        values = [item.get(name) for item in items]
        arrays = [v for v in values if isinstance(v, np.ndarray)]
        if len(arrays) < len(values):
            batch[name] = values
        elif len({(a.shape, a.dtype) for a in arrays}) == 1:
            batch[name] = tensor(np.stack(arrays))
        else:
            batch[name] = [tensor(np.ascontiguousarray(a)) for a in arrays]
    return batch
