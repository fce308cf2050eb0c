"""The build coordinator: broker, writers and workers for one dataset build, until exactly N
samples are durable, then the manifest.

    coordinator ──indices (a pipe per worker)──► workers ──MQTT samples──► broker ──► writer(s)
         ▲                                                                              │
         └──────────────────────── MQTT acks (sample durable in a shard) ◄──────────────┘

The coordinator supervises what it started: a worker that died, fell silent or ran past the
time limit of one sample is killed, replaced and its samples issued again (its
``WorkerPool``, ``datagen/pipeline/worker_pool.py``); a writer or broker
that exited or stopped answering is restarted (``datagen/pipeline/supervise.py``; an external one
is reported, then waited for, then the build stops: docs/liveness.md); a sample not
acknowledged in time is issued again (writers deduplicate by key). A sample whose production
failed (or timed out) on every attempt the config allows (``build.on_sample_error: retry``) is
set aside and the build goes on; it fails at the end listing those samples. ``DIR/build.json``
names the build, so an interrupted build (Ctrl-C, or the coordinator killed) continues with
``resume=True``: the writers re-announce what is already durable and only the rest is rendered.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from pathlib import Path
from typing import Any

from datagen.config import BuildConfig
from datagen.dataset.loader import DatasetError, check_complete
from datagen.errors import BuildError
from datagen.index_set import IndexSet
from datagen.pipeline.executors.base import WorkerSpec
from datagen.pipeline.live_status import LiveStatus
from datagen.pipeline.local_writer import LOCAL_WRITER_ID, LocalWriter
from datagen.pipeline.manifest import build_manifest
from datagen.pipeline.out_dir import BuildIdentity
from datagen.pipeline.result import BuildResult, Observer, ProgressCallback, failed_report
from datagen.pipeline.schedule import Schedule
from datagen.pipeline.supervise import (
    WRITER_READY_TIMEOUT_S,
    Supervisor,
)
from datagen.pipeline.worker_pool import WorkerPool
from datagen.registries import EXECUTORS
from datagen.transport.collector import AckCollector
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.run_binding import RunBinding

log = logging.getLogger(__name__)
FINALIZE_TIMEOUT_S = 300.0


class Coordinator:
    """Drives one build from a running broker to a finalised manifest (see the module doc).

    Workers run in an executor (``datagen.registries.EXECUTORS``) and report events; the
    :class:`Schedule` decides what each worker gets; acks arrive through an
    :class:`AckCollector`. ``run`` returns when the writers have finalised the manifest, or
    raises :class:`BuildError` saying which samples are missing and why.
    """

    def __init__(
        self,
        config: BuildConfig,
        out_dir: Path,
        identity: BuildIdentity,
        workers: int,
        writers: list[str] | None,
        observer: Observer | None,
        on_progress: ProgressCallback | None,
        executor: str = "local",
        executor_options: dict[str, Any] | None = None,
    ):
        self.config = config
        self.out_dir = out_dir
        self.build_id = identity.build_id
        self.secret = identity.secret
        # every run (a --resume too) is a new one: what is signed is bound to it
        self.run_binding = RunBinding.draw(config.to_dict(), config.seed)
        self.num_workers = workers
        self.external_writers = writers
        self.writer_ids = list(writers) if writers else [LOCAL_WRITER_ID]
        self.live = LiveStatus(self.build_id, config.num_samples)  # for monitors: live_status.py
        self.observer = self.live.watching(observer or (lambda event, details: None))
        self.on_progress = on_progress
        self.executor_name, self.executor_options = executor, executor_options or {}
        self.pool: WorkerPool | None = None  # made in run(), once the broker URL is known
        self.writer = (
            LocalWriter(config, out_dir, self.build_id, self.secret) if writers is None else None
        )
        self.schedule: Schedule | None = None
        self.restarts = {"worker": 0, "writer": 0, "broker": 0}
        self.acks: deque[int] = deque()
        self.result = BuildResult(out_dir, 0, 0.0)

    # --- the run -------------------------------------------------------------------------------
    def run(
        self,
        url: str,
        broker: ManagedBroker | None,
        worker_url: str | None = None,
        sample_urls: list[str] | None = None,
    ) -> None:
        """``worker_url``: the workers' own URL for the broker (their user), else ``url``;
        ``sample_urls``: the brokers the workers spread the samples over, else that one."""
        self.url, self.broker = url, broker
        spec = WorkerSpec(
            self.config.to_dict(),
            worker_url or url,
            self.build_id,
            self.secret,
            self.run_binding,
            tuple(sample_urls or ()),
        )
        executor = EXECUTORS[self.executor_name].load()(spec, **self.executor_options)
        self.pool = pool = WorkerPool(
            self.config,
            executor,
            self.num_workers,
            self.observer,
            self.live.on_event,
            self.restarts,
            self.result.retried,
            self._missing,
        )
        total = self.config.num_samples
        self.supervisor = Supervisor(
            self.config,
            self.build_id,
            url,
            broker,
            self.writer,
            self.writer_ids,
            self.observer,
            self.restarts,
            self._missing,
        )
        with (
            self.supervisor,
            AckCollector(
                url,
                self.build_id,
                on_ack=self.acks.append,
                secret=self.secret,
                run=self.run_binding,
                # its client id is new every run: the session only has to outlive an outage
                session_expiry_s=int(
                    self.config.build.outage_wait_s + self.config.build.broker_timeout_s
                )
                + 60,
            ) as collector,
        ):
            self.collector = self.supervisor.collector = collector
            self.live.start(url, self)
            try:
                if self.writer is not None:
                    self.supervisor.start_writer()
                # workers start up (imports, renderer) while the writers get ready
                starting = [pool.spawn() for _ in range(min(self.num_workers, total))]
                self.supervisor.wait_writers_ready(self.result.note_changed)
                if self.external_writers is not None:
                    # writers started earlier re-announce what is durable; ours did before "ready"
                    try:
                        collector.announce(self.writer_ids, timeout_s=WRITER_READY_TIMEOUT_S)
                    except TimeoutError as exc:
                        raise BuildError(str(exc)) from None
                to_make = IndexSet(range(total))  # about a bit a sample, whatever the total
                to_make -= collector.acked
                self.result.resumed_from = total - len(to_make)
                transfer = self.config.transfer
                self.schedule = pool.schedule = Schedule(
                    to_make,
                    transfer.ack_timeout_s,
                    max_unacked=transfer.unacked_per_writer * len(self.writer_ids),
                )
                self.acks.clear()
                self._report(total - self.schedule.not_durable)
                # no idle workers: at most one per sample still to make (a resume may need fewer)
                needed = len(self.schedule.remaining)
                for worker_id in starting[needed:]:
                    pool.dismiss(worker_id)
                for worker_id in starting[:needed]:
                    pool.take_on(worker_id)
                self._drive(self.schedule, pool)
                if pool.failed:
                    raise BuildError(failed_report(pool.failed, total, self.config.build.retries))
                manifest = build_manifest(self.config, self.build_id, self.num_workers)
                self.result.rejected = collector.rejected
                manifest["rejected_control_messages_coordinator"] = self.result.rejected
                manifest["run"] = self.run_binding.run  # the run that finished it
                if self.result.retried:
                    manifest["retried_samples"] = {
                        str(i): r for i, r in sorted(self.result.retried.items())
                    }
                self.supervisor.finalize(total, manifest, FINALIZE_TIMEOUT_S)
                self._check_on_disk()
                self.live.finish()
                pool.stop(graceful=True)
                if self.writer is not None:
                    self.writer.wait(timeout_s=30)
            except BaseException as exc:
                self.live.fail(exc)
                raise
            finally:
                self.live.close()
                pool.stop(graceful=False)
                self._stop_writer()
        self.result.samples = total
        self.result.reissued = self.schedule.reissued
        self.result.latency = self.schedule.latency.summary()
        self.result.restarts = dict(self.restarts)

    def _drive(self, schedule: Schedule, pool: WorkerPool) -> None:
        total = self.config.num_samples
        while True:
            now = time.monotonic()
            while self.acks:
                index = self.acks.popleft()
                if 0 <= index < total:
                    schedule.on_acked(index, now)
            self._report(total - schedule.not_durable)
            if schedule.done:
                return
            self.supervisor.check()
            pool.handle_messages()
            now = time.monotonic()
            pool.supervise(now)
            overdue = schedule.reissue_overdue(now)
            if overdue:
                log.warning(
                    "%d samples not durable %.0f s after publishing; issuing them again: %s",
                    len(overdue),
                    self.config.transfer.ack_timeout_s,
                    overdue[:10],
                )
            pool.feed_all()

    @property
    def failed(self) -> dict[int, list[str]]:
        """Samples set aside after failing every attempt: index -> failures (the live status)."""
        return self.pool.failed if self.pool is not None else {}

    def _report(self, done: int) -> None:
        self.live.tick()
        if self.on_progress:
            self.on_progress(done, self.config.num_samples)

    # --- writers and the broker (restarts and reports: supervise.py) ---------------------------
    def _stop_writer(self) -> None:
        if self.writer is None:
            return
        if self.supervisor.broker_answers():
            self.writer.stop()
        else:  # it could not drain through a hung broker; its journal keeps what is durable
            self.writer.kill()

    def _missing(self, reason: str) -> str:
        if self.schedule is None:  # before any sample was issued
            return reason
        missing = sorted(self.schedule.remaining)
        total = self.config.num_samples
        shown = ", ".join(map(str, missing[:20])) + (" ..." if len(missing) > 20 else "")
        return f"{reason}; {len(missing)} of {total} samples are not durable: {shown}"

    def _check_on_disk(self) -> None:
        """Success means the data is there: the finished manifest is this build's, and the
        shards hold every sample 0..N-1 exactly once with the sizes and digests it lists."""
        try:
            manifest = check_complete(self.out_dir, self.config.num_samples, self.build_id)
        except DatasetError as exc:
            raise BuildError(f"the writers reported the dataset finished, but {exc}") from None
        if manifest.get("run") != self.run_binding.run:
            raise BuildError(
                f"the writers finished the dataset, but its manifest is of run "
                f"{manifest.get('run')!r}, not of this run {self.run_binding.run!r}"
            )
