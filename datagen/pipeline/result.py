"""What a finished build reports, and the callbacks it reports through on the way."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from datagen.records import ProductionRecord


@dataclass
class BuildResult:
    out_dir: Path
    samples: int
    seconds: float
    already_complete: bool = False
    resumed_from: int = 0  # samples already durable when the build (re)started
    reissued: int = 0
    restarts: dict[str, int] = field(default_factory=dict)
    retried: dict[int, ProductionRecord] = field(default_factory=dict)  # index -> its retries
    rejected: dict[str, int] = field(default_factory=dict)  # control messages dropped, by reason
    # samples a resumed build found changed on disk since they were made durable: made again
    changed: int = 0
    changed_keys: list[str] = field(default_factory=list)  # the first few
    # seconds from a worker's report that it published a sample to a writer's ack of it:
    # {"samples", "p50_s", "p90_s", "p99_s", "max_s"} (datagen.pipeline.latency)
    latency: dict[str, float] = field(default_factory=dict)

    def note_changed(self, ready: dict[str, Any]) -> None:
        """Counts what a writer's ``ready`` status says it removed as changed on disk."""
        count, keys = ready.get("changed"), ready.get("changed_keys")
        if isinstance(count, int) and count > 0 and isinstance(keys, list):
            self.changed += count
            self.changed_keys += [k for k in keys[:10] if isinstance(k, str)]


ProgressCallback = Callable[[int, int], None]  # (samples durable, samples requested)
# (event, details): "broker" {url, pid}, "writer" {id, pid}, "worker" {id, pid}, "restart"
# {what, why, ...} (a process restarted), "stall" {problem, wait_s} (an external writer or broker
# is silent: the build waits wait_s more, then stops), "recycle" {id, samples}
Observer = Callable[[str, dict[str, Any]], None]


def failed_report(failed: dict[int, list[str]], total: int, retries: int) -> str:
    """The error of a build whose samples ``failed`` (index -> failures) on every attempt."""
    lines = [
        f"{len(failed)} of {total} samples failed on every attempt "
        f"(build.on_sample_error: retry, build.retries: {retries}); the "
        f"other samples are durable, and --resume retries these: {sorted(failed)}"
    ]
    for index, failures in sorted(failed.items())[:20]:
        lines += [f"  sample {index}:", *(f"    {f}" for f in failures)]
    return "\n".join(lines)
