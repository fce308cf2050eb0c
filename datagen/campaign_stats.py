"""Campaign statistics from grasp outcomes (:mod:`datagen.outcomes`): the ``campaign`` of the
manifest, of ``datagen inspect`` and of the live status, one spelling for all."""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping
from typing import Any


def _rate(successes: int, attempts: int) -> float:
    return round(successes / attempts, 4) if attempts else 0.0


def campaign_stats(
    outcomes: Iterable[Mapping[str, Any]], seconds: float | None = None
) -> dict[str, Any]:
    """Success rates overall, per sampler and per shape family, and failure-mode counts, of
    grasp outcomes (each sample counted once). ``disturbed`` attempts (an object moved faster
    than the hand could push it: ``datagen.families.grasp_attempts.disturbance``) are failures of the physics,
    not of the grasp: counted apart, and left out of ``success_rate_undisturbed``."""
    total, successes = 0, 0
    by_sampler: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    by_family: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    failures: Counter[str] = Counter()
    for outcome in outcomes:
        success = bool(outcome["success"])
        total += 1
        successes += success
        for table, key in (
            (by_sampler, outcome["sampler"]),
            (by_family, outcome["family"]),
        ):
            table[key][0] += 1
            table[key][1] += success
        if not success:
            failures[outcome["failure_mode"]] += 1

    def rows(table):
        return {
            k: {"attempts": a, "successes": s, "success_rate": _rate(s, a)}
            for k, (a, s) in sorted(table.items())
        }

    disturbed = failures["disturbed"]
    stats = {
        "attempts": total,
        "successes": successes,
        "success_rate": _rate(successes, total),
        "disturbed": disturbed,
        "success_rate_undisturbed": _rate(successes, total - disturbed),
        "per_sampler": rows(by_sampler),
        "per_family": rows(by_family),
        "failure_modes": dict(sorted(failures.items())),
    }
    if seconds:
        stats["attempts_per_s"] = round(total / seconds, 4)
    return stats
