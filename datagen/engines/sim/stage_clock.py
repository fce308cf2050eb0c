"""Seconds a worker process spends per stage of producing a sample, for the stage benchmarks
(``DATAGEN_STAGE_LOG``). Measurement only: nothing reads it to decide anything."""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager

_seconds: defaultdict[str, float] = defaultdict(float)


@contextmanager
def timed(stage: str) -> Iterator[None]:
    start = time.perf_counter()
    try:
        yield
    finally:
        _seconds[stage] += time.perf_counter() - start


def take() -> dict[str, float]:
    """``{stage + "_s": seconds}`` since the last call, and starts again from zero."""
    out = {f"{stage}_s": s for stage, s in _seconds.items()}
    _seconds.clear()
    return out
