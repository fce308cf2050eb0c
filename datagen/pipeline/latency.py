"""End-to-end latency of a build's samples, in constant memory: a histogram over log-spaced
bins (``BINS_PER_DECADE`` per factor of ten, from 1 ms to 1000 s), so a 100,000-sample build
keeps as many numbers as a 10-sample one. A percentile is the upper edge of its bin (at most
12 % above the true value at 20 bins per decade)."""

from __future__ import annotations

import math

BINS_PER_DECADE = 20
LOWEST_S, DECADES = 1e-3, 6  # 1 ms .. 1000 s; outside: the first or last bin


class LatencyHistogram:
    def __init__(self) -> None:
        self.counts = [0] * (BINS_PER_DECADE * DECADES + 1)
        self.count = 0
        self.max_s = 0.0

    def add(self, seconds: float) -> None:
        position = math.log10(max(seconds, LOWEST_S) / LOWEST_S) * BINS_PER_DECADE
        self.counts[min(len(self.counts) - 1, int(position))] += 1
        self.count += 1
        self.max_s = max(self.max_s, seconds)

    def percentile(self, p: float) -> float:
        """The upper edge of the bin holding the ``p``-th percentile (0 < p <= 100), in
        seconds, capped at the largest latency seen; 0.0 when nothing was added."""
        if not self.count:
            return 0.0
        rank, seen = math.ceil(p / 100 * self.count), 0
        for k, n in enumerate(self.counts):
            seen += n
            if seen >= rank:
                if k == len(self.counts) - 1:  # past 1000 s: the bin has no upper edge
                    return self.max_s
                return min(self.max_s, LOWEST_S * 10 ** ((k + 1) / BINS_PER_DECADE))
        return self.max_s

    def summary(self) -> dict[str, float]:
        """``{"samples", "p50_s", "p90_s", "p99_s", "max_s"}`` (seconds, 4 decimals)."""
        points = {f"p{p}_s": round(self.percentile(p), 4) for p in (50, 90, 99)}
        return {"samples": self.count, **points, "max_s": round(self.max_s, 4)}
