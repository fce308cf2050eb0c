"""Seconds a worker process spends per stage of producing a sample, for the stage benchmarks
(``DATAGEN_STAGE_LOG``, ``benchmarks/stages.py``). Measurement only: nothing reads it to decide
anything.

Wall seconds (``take``) and process CPU seconds (``take_cpu``: ``time.process_time``, the CPU of
every thread of the process, lavapipe's rasteriser threads and the PNG pool included).
Stages: build, settle, render, read_back, convert, encode (see the modules that time them).
"""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager

_seconds: defaultdict[str, float] = defaultdict(float)
_cpu_seconds: defaultdict[str, float] = defaultdict(float)


@contextmanager
def timed(stage: str) -> Iterator[None]:
    start, cpu_start = time.perf_counter(), time.process_time()
    try:
        yield
    finally:
        _seconds[stage] += time.perf_counter() - start
        _cpu_seconds[stage] += time.process_time() - cpu_start


def take() -> dict[str, float]:
    """``{stage + "_s": seconds}`` since the last call, and starts again from zero."""
    out = {f"{stage}_s": s for stage, s in _seconds.items()}
    _seconds.clear()
    return out


def take_cpu() -> dict[str, float]:
    """``{stage + "_s": process CPU seconds}`` since the last call, and starts again from zero."""
    out = {f"{stage}_s": s for stage, s in _cpu_seconds.items()}
    _cpu_seconds.clear()
    return out
