"""The build's workers: started in an executor (``datagen.registries.EXECUTORS``), fed the
indices the :class:`Schedule` gives each, heard from, recycled, and replaced when they die,
fall silent or run past the time limit of one sample (their unfinished samples issued again).
The coordinator drives it; the broker and the writers are the supervisor's
(``datagen/pipeline/supervise.py``)."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

from datagen.config import BuildConfig
from datagen.errors import BuildError
from datagen.pipeline.liveness import Attempt, WorkerWatch, timed_out
from datagen.pipeline.production import Task
from datagen.pipeline.result import Observer
from datagen.pipeline.schedule import Schedule
from datagen.pipeline.supervise import MAX_RESTARTS
from datagen.records import ProductionRecord

log = logging.getLogger(__name__)
POLL_S = 0.1
SUPERVISE_EVERY_S = 0.5


class WorkerPool:
    """``executor``'s workers for one build. ``schedule`` is set once the writers have said
    what is left to make; ``on_event(worker, kind, payload)`` hears every worker message (the
    live status); ``retried`` collects the samples that needed more than one attempt;
    ``missing(reason)`` says which samples are not durable, for a build that stops."""

    def __init__(
        self,
        config: BuildConfig,
        executor: Any,
        size: int,
        observer: Observer,
        on_event: Callable[[int, str, Any], None],
        restarts: dict[str, int],
        retried: dict[int, ProductionRecord],
        missing: Callable[[str], str],
    ):
        self.config, self.executor, self.size = config, executor, size
        self.observer, self.on_event, self.missing = observer, on_event, missing
        self.restarts, self.retried = restarts, retried
        self.schedule: Schedule | None = None
        self.workers: dict[int, int] = {}  # live worker id -> samples it has published
        self.retiring: set[int] = set()
        self.dismissed: set[int] = set()
        self.next_worker_id = 0
        self.failed: dict[int, list[str]] = {}  # index -> failures of every attempt
        self.next_task: dict[int, Task] = {}  # samples to resume at a later attempt (timed out)
        limits = config.build
        self.watch = WorkerWatch(limits.worker_timeout_s, limits.sample_timeout_s)
        self._next_look = 0.0

    @property
    def _schedule(self) -> Schedule:
        assert self.schedule is not None, "the pool is fed once the schedule is known"
        return self.schedule

    def spawn(self) -> int:
        """Starts a worker process (or actor); the schedule gives it samples once it is added."""
        worker_id = self.next_worker_id
        self.next_worker_id += 1
        details = self.executor.start(worker_id)
        self.watch.add(worker_id, time.monotonic())
        self.workers[worker_id] = 0
        self.observer("worker", {"id": worker_id, **details})
        return worker_id

    def take_on(self, worker_id: int) -> None:
        """A spawned worker joins the schedule and gets its first samples."""
        self._schedule.add_worker(worker_id)
        self.feed(worker_id)

    def dismiss(self, worker_id: int) -> None:
        """A worker started before the writers said how much is left, and not needed: it stops
        without samples, and what it still sends is ignored."""
        self.dismissed.add(worker_id)
        self.executor.retire(worker_id)
        self.watch.forget(worker_id)
        self.workers.pop(worker_id, None)

    def feed(self, worker_id: int) -> None:
        if worker_id in self.retiring:
            return
        for index in self._schedule.next_for(worker_id):
            if not self.executor.send(worker_id, self.next_task.get(index, Task(index))):
                return  # it died; poll reports it

    def feed_all(self) -> None:
        """Feeds the workers with room for more (not every worker: at 1,000 workers a loop
        over all of them on every poll cost the coordinator more than the samples did)."""
        for worker_id in self._schedule.hungry_workers():
            if worker_id in self.workers:
                self.feed(worker_id)

    def handle_messages(self) -> None:
        """What the workers reported during one poll (at most ``POLL_S`` of waiting)."""
        recycle_after = self.config.executor.recycle_after
        schedule = self._schedule
        for worker_id, kind, payload in self.executor.poll(POLL_S):
            if worker_id in self.dismissed:
                continue  # started early and not needed (dismiss)
            now = time.monotonic()
            self.on_event(worker_id, kind, payload)
            self.watch.heard_from(worker_id, now)
            if kind == "ready":
                self.watch.ready(worker_id)
            elif kind == "started":
                self.watch.started(worker_id, payload, now)
            elif kind == "published":
                self.watch.finished(worker_id, payload)
                schedule.on_published(worker_id, payload, now)
                self.workers[worker_id] += 1
                if recycle_after and self.workers[worker_id] >= recycle_after:
                    self._retire(worker_id)
            elif kind == "retried":
                record = ProductionRecord(attempt=payload["attempt"], failures=payload["failures"])
                self.retried[payload["index"]] = record
            elif kind == "failed":
                self.watch.finished(worker_id, payload["index"])
                self.failed[payload["index"]] = payload["failures"]
                schedule.on_given_up(worker_id, payload["index"])
            elif kind == "error":
                raise BuildError(payload)
            elif kind == "lost":
                self._lose(worker_id, payload)
            elif kind == "done":
                self.watch.forget(worker_id)
                self.workers.pop(worker_id, None)
                if worker_id in self.retiring:  # recycled: published samples stay tracked
                    self.retiring.discard(worker_id)
                    schedule.on_worker_lost(worker_id, keep_published=True)
                    if not schedule.done:
                        self.take_on(self.spawn())

    def supervise(self, now: float) -> None:
        """Kills a worker that fell silent or ran past the time limit of one sample; a timed-out
        attempt counts as a failed one (``build.on_sample_error``). Looks at most once every
        ``SUPERVISE_EVERY_S`` (a look visits every worker; the limits are seconds long)."""
        if now < self._next_look:
            return
        self._next_look = now + SUPERVISE_EVERY_S
        for stuck in self.watch.unresponsive(now):
            self.executor.kill(stuck.worker)
            if stuck.attempt is not None:
                self._attempt_timed_out(stuck.worker, stuck.attempt)
            self._lose(stuck.worker, f"killed: it {stuck.why}")

    def stop(self, graceful: bool) -> None:
        self.executor.stop(graceful)
        self.workers.clear()

    def _retire(self, worker_id: int) -> None:
        """Recycling: the worker finishes what it holds and stops; a fresh one replaces it."""
        if worker_id not in self.retiring:
            self.retiring.add(worker_id)
            self.observer("recycle", {"id": worker_id, "samples": self.workers[worker_id]})
            self.executor.retire(worker_id)

    def _attempt_timed_out(self, worker_id: int, attempt: Attempt) -> None:
        limits, index = self.config.build, attempt.index
        failures = timed_out(attempt, limits.sample_timeout_s)
        if limits.on_sample_error != "retry":
            raise BuildError(
                f"sample {index} timed out after {limits.sample_timeout_s:g} s "
                f"(build.sample_timeout_s; build.on_sample_error: fail); its worker was killed"
            )
        if attempt.attempt >= limits.retries:
            self.failed[index] = failures
            self._schedule.on_given_up(worker_id, index)
        else:
            self.next_task[index] = Task(index, attempt.attempt + 1, tuple(failures))

    def _lose(self, worker_id: int, why: str) -> None:
        self.watch.forget(worker_id)
        self.workers.pop(worker_id, None)
        self.retiring.discard(worker_id)
        lost = self._schedule.on_worker_lost(worker_id)
        self.restarts["worker"] += 1
        log.warning(
            "worker %d %s; issuing its %d unfinished samples again and starting a new worker",
            worker_id,
            why if why.startswith("killed") else f"died ({why})",
            len(lost),
        )
        self.observer("restart", {"what": "worker", "id": worker_id, "why": why, "reissued": lost})
        if self.restarts["worker"] > MAX_RESTARTS * max(1, self.size):
            raise BuildError(self.missing("workers keep dying"))
        self.take_on(self.spawn())
