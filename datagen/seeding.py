"""Every random choice comes from a generator derived from (build seed, sample index, stream).

Streams are named per randomiser, so adding or reordering one randomiser never changes the
values another draws, and sample i is the same whichever worker renders it, in whatever order.
"""

from __future__ import annotations

import zlib

import numpy as np


def stream_id(name: str) -> int:
    return zlib.crc32(name.encode("utf-8"))


def sample_rng(seed: int, index: int, stream: str, attempt: int = 0) -> np.random.Generator:
    """The generator for one named stream of one sample of one build. ``attempt`` k > 0 (a
    retry after producing the sample failed) gives fresh streams, still a function of
    (seed, index, k) alone; attempt 0 is the sample as it is first drawn."""
    key = (index, stream_id(stream)) if attempt == 0 else (index, stream_id(stream), attempt)
    return np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=key))
