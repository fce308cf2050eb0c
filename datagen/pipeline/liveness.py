"""Who has gone quiet, and who is stuck: pure bookkeeping (no processes, no clock of its own;
the coordinator passes ``now``, seconds of ``time.monotonic()``).

A worker is *silent* when nothing came from it (heartbeats every 2 s, from its start) for
``build.worker_timeout_s``: stopped, deadlocked, or holding the GIL in one C call. Until it
reports ``ready`` it gets ``STARTUP_GRACE_S`` more: start-up holds the GIL for seconds (SAPIEN's
renderer warm-up: ~3.5 s on lavapipe, 10 s measured on a loaded 2-core machine). It is *stuck*
when one attempt at one sample has run for ``build.sample_timeout_s`` while its heartbeats go on.
Either way the coordinator kills it; only a stuck attempt counts against the sample.
"""

from __future__ import annotations

from dataclasses import dataclass

from datagen.records import AttemptRecord

STARTUP_GRACE_S = 60.0


@dataclass(frozen=True)
class Attempt:
    index: int
    attempt: int
    failures: tuple[str, ...]  # of the earlier attempts
    since: float


@dataclass(frozen=True)
class Unresponsive:
    worker: int
    why: str
    attempt: Attempt | None  # the attempt that ran past the time limit (None: silent worker)


class WorkerWatch:
    def __init__(self, silence_s: float, attempt_s: float):
        self.silence_s, self.attempt_s = silence_s, attempt_s
        self.heard: dict[int, float] = {}
        self.working: dict[int, Attempt] = {}
        self.starting: set[int] = set()

    def add(self, worker: int, now: float) -> None:
        """A worker just started: its silence counts from now (start-up included)."""
        self.heard[worker] = now
        self.starting.add(worker)

    def ready(self, worker: int) -> None:
        """Its start-up is over: no more grace."""
        self.starting.discard(worker)

    def heard_from(self, worker: int, now: float) -> None:
        if worker in self.heard:
            self.heard[worker] = now

    def started(self, worker: int, payload: AttemptRecord, now: float) -> None:
        """A ``started`` event."""
        failures = tuple(payload.get("failures", ()))
        self.working[worker] = Attempt(payload["index"], payload["attempt"], failures, now)

    def finished(self, worker: int, index: int) -> None:
        """Published or given up: the worker no longer works on ``index``."""
        if worker in self.working and self.working[worker].index == index:
            del self.working[worker]

    def forget(self, worker: int) -> None:
        self.heard.pop(worker, None)
        self.working.pop(worker, None)
        self.starting.discard(worker)

    def unresponsive(self, now: float) -> list[Unresponsive]:
        found = []
        for worker, heard in self.heard.items():
            attempt = self.working.get(worker)
            grace = STARTUP_GRACE_S if worker in self.starting else 0.0
            if now - heard > self.silence_s + grace:
                why = f"sent nothing for {now - heard:.0f} s"
                why += f" (build.worker_timeout_s: {self.silence_s:g})"
                found.append(Unresponsive(worker, why, None))
            elif attempt is not None and now - attempt.since > self.attempt_s:
                why = (
                    f"spent more than {self.attempt_s:g} s on attempt {attempt.attempt} at "
                    f"sample {attempt.index} (build.sample_timeout_s)"
                )
                found.append(Unresponsive(worker, why, attempt))
        return found


def timed_out(attempt: Attempt, limit_s: float) -> list[str]:
    """The sample's failures, this attempt's time-out added (as a failure of it is recorded)."""
    why = f"timed out after {limit_s:g} s (build.sample_timeout_s); its worker was killed"
    return [*attempt.failures, f"attempt {attempt.attempt}: {why}"]


@dataclass
class Silence:
    """One service (a writer, the broker) the build depends on and may not restart itself:
    when it went quiet, and whether that was reported."""

    since: float  # last sign of life (or the moment watching began)
    grace: float = 0.0  # more seconds allowed until the first sign of life after ``since``
    reported: bool = False

    def silent_s(self, now: float, heard: float | None) -> float:
        if heard is not None and heard > self.since:
            self.since, self.grace = heard, 0.0
        return now - self.since
