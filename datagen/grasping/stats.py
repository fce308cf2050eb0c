"""Campaign statistics from attempt records (the ``attempt`` block of each sample's metadata)."""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Iterable
from typing import Any


def _rate(successes: int, attempts: int) -> float:
    return round(successes / attempts, 4) if attempts else 0.0


def campaign_stats(
    attempts: Iterable[dict[str, Any]], seconds: float | None = None
) -> dict[str, Any]:
    """Success rates overall, per sampler and per shape family, and failure-mode counts."""
    total, successes = 0, 0
    by_sampler: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    by_family: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    failures: Counter[str] = Counter()
    for attempt in attempts:
        success = bool(attempt["outcome"]["success"])
        total += 1
        successes += success
        for table, key in (
            (by_sampler, attempt["sampler"]),
            (by_family, attempt["target"]["class"]),
        ):
            table[key][0] += 1
            table[key][1] += success
        if not success:
            failures[attempt["outcome"]["failure_mode"]] += 1

    def rows(table):
        return {
            k: {"attempts": a, "successes": s, "success_rate": _rate(s, a)}
            for k, (a, s) in sorted(table.items())
        }

    stats = {
        "attempts": total,
        "successes": successes,
        "success_rate": _rate(successes, total),
        "per_sampler": rows(by_sampler),
        "per_family": rows(by_family),
        "failure_modes": dict(sorted(failures.items())),
    }
    if seconds:
        stats["attempts_per_s"] = round(total / seconds, 4)
    return stats
