"""Progress of a build or an export: a tqdm bar on a terminal; elsewhere (output piped or written
to a file, where a bar would leave a line per update) one plain line per interval and one at
the end::

    datagen: 120/1000 durable, 3.4 samples/s, ETA 4m18s

The interval is 10 s, or ``$DATAGEN_PROGRESS_INTERVAL_S`` seconds.
"""

from __future__ import annotations

import os
import sys
import time
from typing import TextIO

INTERVAL_ENV = "DATAGEN_PROGRESS_INTERVAL_S"
DEFAULT_INTERVAL_S = 10.0


def _interval() -> float:
    try:
        return max(0.0, float(os.environ.get(INTERVAL_ENV, DEFAULT_INTERVAL_S)))
    except ValueError:
        return DEFAULT_INTERVAL_S


def duration(seconds: float) -> str:
    """``4m18s``, ``1h02m``, ``7s``."""
    seconds = round(seconds)
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"


class PlainProgress:
    """Plain progress lines on ``stream``: at most one per ``interval_s`` and one at the end."""

    def __init__(
        self,
        total: int,
        desc: str,
        unit: str = "samples",
        stream: TextIO | None = None,
        interval_s: float | None = None,
        clock=time.monotonic,
    ):
        self.total, self.desc, self.unit = total, desc, unit
        self.stream = stream or sys.stderr
        self.interval_s = _interval() if interval_s is None else interval_s
        self.clock = clock
        self.n = 0
        self._first: tuple[float, int] | None = None  # (time, done) of the first report
        self._printed_at = clock()
        self._printed_n: int | None = None

    def update_to(self, done: int) -> None:
        now = self.clock()
        if self._first is None:
            self._first = (now, done)
        self.n = done
        if done >= self.total or now - self._printed_at >= self.interval_s:
            self._print(now)

    def close(self) -> None:
        pass  # the last line was printed when done reached total

    def _print(self, now: float) -> None:
        if self._printed_n == self.n:
            return
        start, start_n = self._first or (now, self.n)
        rate = (self.n - start_n) / (now - start) if now > start else 0.0
        if self.n >= self.total:
            tail = f"in {duration(now - start)}"
        else:
            tail = f"ETA {duration((self.total - self.n) / rate)}" if rate > 0 else "ETA ?"
        print(
            f"datagen: {self.n}/{self.total} {self.desc}, {rate:.1f} {self.unit}/s, {tail}",
            file=self.stream,
            flush=True,
        )
        self._printed_at, self._printed_n = now, self.n


class _Bar:
    """tqdm with the same ``update_to``/``close`` as PlainProgress."""

    def __init__(self, total: int, desc: str, unit: str, leave: bool):
        from tqdm import tqdm

        self.bar = tqdm(
            total=total,
            unit=unit.rstrip("s"),
            dynamic_ncols=True,
            desc=desc,
            smoothing=0.1,
            leave=leave,
        )

    def update_to(self, done: int) -> None:
        self.bar.update(done - self.bar.n)

    def close(self) -> None:
        self.bar.close()


def progress(total: int, desc: str, unit: str = "samples", leave: bool = True):
    """A tqdm bar when stderr (where it is drawn) is a terminal, else PlainProgress."""
    if sys.stderr.isatty():
        return _Bar(total, desc, unit, leave)
    return PlainProgress(total, desc, unit)


class LazyProgress:
    """A progress callback ``(done, total)`` that opens its bar at the first call, when the
    total is known; ``close()`` closes it if it was opened."""

    def __init__(self, desc: str, unit: str = "samples"):
        self.desc, self.unit = desc, unit
        self.bar: PlainProgress | _Bar | None = None

    def __call__(self, done: int, total: int) -> None:
        self.bar = self.bar or progress(total, self.desc, unit=self.unit)
        self.bar.update_to(done)

    def close(self) -> None:
        if self.bar:
            self.bar.close()
