"""The build coordinator: broker, writers and workers for one dataset build, until exactly N
samples are durable, then the manifest.

    coordinator ──indices (a pipe per worker)──► workers ──MQTT samples──► broker ──► writer(s)
         ▲                                                                              │
         └──────────────────────── MQTT acks (sample durable in a shard) ◄──────────────┘

The coordinator supervises what it started: a dead worker is replaced and its samples issued
again, a dead writer or broker is restarted, and a sample not acknowledged in time is issued
again (writers deduplicate by key). ``DIR/build.json`` names the build, so an interrupted build
(Ctrl-C, or the coordinator killed) continues with ``resume=True``: the writers re-announce what
is already durable and only the rest is rendered.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import platform
import secrets
import shutil
import subprocess
import sys
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

from datagen.build.executors.local_processes import WorkerSpec, make_executor
from datagen.build.schedule import Schedule
from datagen.build.worker import die_with_parent
from datagen.config import BuildConfig
from datagen.engines.transfer.collector import AckCollector
from datagen.engines.transfer.mosquitto import ManagedBroker
from datagen.engines.transfer.wire import SECRET_ENV, parse_secret
from datagen.engines.transfer.wire import VERSION as WIRE_VERSION
from datagen.exports.runner import run_exports
from datagen.shards import MANIFEST, write_manifest
from datagen.worlds.floorplan import NAV_CLASSES
from datagen.worlds.tabletop import grasp_classes

log = logging.getLogger(__name__)
BUILD_STATE = "build.json"
DATASET_FORMAT = "datagen.dataset/1"
LOCAL_WRITER_ID = "0"
_VERSIONED_PACKAGES = (
    "datagen",
    "sapien",
    "mani-skill",
    "numpy",
    "opencv-python-headless",
    "trimesh",
    "paho-mqtt",
)
WRITER_READY_TIMEOUT_S = 60.0
FINALIZE_TIMEOUT_S = 300.0
MAX_RESTARTS = 10  # of each kind (worker, writer, broker) before the build gives up
POLL_S = 0.1


class BuildError(RuntimeError):
    """The build cannot finish; the message says what is missing and why."""


@dataclass
class BuildResult:
    out_dir: Path
    samples: int
    seconds: float
    already_complete: bool = False
    resumed_from: int = 0  # samples already durable when the build (re)started
    reissued: int = 0
    restarts: dict[str, int] = field(default_factory=dict)


ProgressCallback = Callable[[int, int], None]  # (samples durable, samples requested)
# (event, details): "broker" {url, pid}, "writer" {id, pid}, "worker" {id, pid}, "restart" {...}
Observer = Callable[[str, dict[str, Any]], None]


def _versions() -> dict[str, str]:
    versions = {"python": platform.python_version(), "platform": platform.platform()}
    for name in _VERSIONED_PACKAGES:
        with contextlib.suppress(metadata.PackageNotFoundError):
            versions[name] = metadata.version(name)
    return versions


def _read_json(path: Path) -> dict[str, Any] | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


@dataclass(frozen=True)
class BuildIdentity:
    build_id: str
    secret: bytes  # signs every sample; writers with it reject samples not signed with it


def prepare_out_dir(
    out_dir: Path, config: BuildConfig, overwrite: bool, resume: bool, build_id: str | None
) -> tuple[BuildIdentity | None, bool]:
    """Returns (build identity, already complete). Refuses to mix builds in one directory."""
    manifest = _read_json(out_dir / MANIFEST)
    if (
        not overwrite
        and manifest
        and manifest.get("config") == config.to_dict()
        and manifest.get("samples") == config.num_samples
    ):
        return None, True
    state = _read_json(out_dir / BUILD_STATE)
    if resume and not overwrite:
        if state is None:
            raise BuildError(
                f"{out_dir}: nothing to resume (no {BUILD_STATE}); start it without --resume"
            )
        if state.get("config") != config.to_dict():
            differing = sorted(
                k for k in config.to_dict() if state.get("config", {}).get(k) != config.to_dict()[k]
            )
            raise BuildError(
                f"{out_dir} was started with another config (differs in: {', '.join(differing)}); "
                "resume with the same config, seed and sample count"
            )
        try:
            return BuildIdentity(state["build_id"], parse_secret(state["secret"])), False
        except (KeyError, ValueError) as exc:
            raise BuildError(f"{out_dir / BUILD_STATE}: unreadable build state ({exc})") from None
    if out_dir.exists() and any(out_dir.iterdir()):
        if not overwrite:
            hint = " or pass --resume to finish it" if state else ""
            raise BuildError(
                f"{out_dir} is not empty and does not hold a complete build of this config "
                f"(same config, seed and sample count); choose another --out{hint}, "
                f"or pass --overwrite to replace it"
            )
        shutil.rmtree(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    try:
        secret = parse_secret(os.environ[SECRET_ENV]) if os.environ.get(SECRET_ENV) else None
    except ValueError as exc:
        raise BuildError(str(exc)) from None
    identity = BuildIdentity(build_id or secrets.token_hex(6), secret or secrets.token_bytes(32))
    state = {
        "build_id": identity.build_id,
        "secret": identity.secret.hex(),
        "config": config.to_dict(),
        "started_utc": _now(),
    }
    write_manifest(out_dir, state, name=BUILD_STATE, mode=0o600)  # it holds the secret
    return identity, False


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def build_manifest(config: BuildConfig, build_id: str, workers: int) -> dict[str, Any]:
    return {
        "dataset_format": DATASET_FORMAT,
        "build_id": build_id,
        "created_utc": _now(),
        "scene": config.scene,
        "seed": config.seed,
        "num_samples": config.num_samples,
        "workers": workers,
        "classes": list(NAV_CLASSES if config.scene == "navigation" else grasp_classes(config)),
        "wire_format_version": WIRE_VERSION,
        "config": config.to_dict(),
        "versions": _versions(),
    } | _asset_report(config)


def _asset_report(config: BuildConfig) -> dict[str, Any]:
    if config.objects.source != "folder":
        return {}
    from datagen.mesh_library import load_library

    return {"assets": load_library(config.objects.assets_dir).report()}


def run_build(
    config: BuildConfig,
    out_dir: str | os.PathLike,
    workers: int,
    overwrite: bool = False,
    on_progress: ProgressCallback | None = None,
    *,
    resume: bool = False,
    broker_url: str | None = None,
    writers: list[str] | None = None,
    build_id: str | None = None,
    observer: Observer | None = None,
    executor: str = "local",
    ray_address: str | None = None,
) -> BuildResult:
    """Builds ``config.num_samples`` samples into ``out_dir``.

    ``broker_url``: an MQTT v5 broker to use instead of starting Mosquitto. ``writers``: ids of
    writers started elsewhere (``datagen writer``) instead of one local writer. ``executor``:
    ``local`` (processes of this machine) or ``ray`` (actors; ``ray_address`` None starts a local
    Ray instance, ``auto`` or ``ray://host:port`` joins a cluster).
    """
    out_dir = Path(out_dir)
    start = time.monotonic()
    identity, complete = prepare_out_dir(out_dir, config, overwrite, resume, build_id)
    if complete:
        run_exports(out_dir, config.output.sinks)  # finishes an interrupted export, if any
        return BuildResult(out_dir, config.num_samples, 0.0, already_complete=True)
    if executor == "ray" and ray_address and not broker_url:
        raise BuildError(
            "--executor ray on a cluster needs a broker every node can reach: pass --broker "
            "mqtt://HOST:PORT (see docs/deployment.md, 'Ray cluster')"
        )
    options = {}
    if executor == "ray":
        options = {
            "address": ray_address,
            "cpus_per_worker": config.executor.cpus_per_worker,
            "gpus_per_worker": config.executor.gpus_per_worker,
        }
    coordinator = _Coordinator(
        config, out_dir, identity, workers, writers, observer, on_progress, executor, options
    )
    with _broker(config, broker_url, observer) as (url, broker):
        coordinator.run(url, broker)
    result = coordinator.result
    result.seconds = time.monotonic() - start
    if config.scene == "grasp_attempts" and (out_dir / MANIFEST).is_file():
        _add_campaign_stats(
            out_dir, made=result.samples - result.resumed_from, seconds=result.seconds
        )
    if (out_dir / MANIFEST).is_file():
        run_exports(out_dir, config.output.sinks)
    return result


def _add_campaign_stats(out_dir: Path, made: int, seconds: float) -> None:
    """Campaign statistics go into the manifest (the writers know nothing of grasps)."""
    from datagen.dataset.loader import load
    from datagen.grasping.stats import campaign_stats

    dataset = load(out_dir)
    stats = campaign_stats(dataset.metadata(i)["attempt"] for i in range(len(dataset)))
    stats["attempts_per_s"] = round(made / seconds, 4) if seconds else None
    manifest = json.loads((out_dir / MANIFEST).read_text())
    write_manifest(out_dir, manifest | {"campaign": stats})


@contextlib.contextmanager
def _broker(
    config: BuildConfig, broker_url: str | None, observer: Observer | None
) -> Iterator[tuple[str, ManagedBroker | None]]:
    if broker_url:
        yield broker_url, None
        return
    max_bytes = int(config.transfer.max_sample_mb * 2**20) + 2**16  # + wire header room
    with ManagedBroker(max_message_bytes=max_bytes, preexec_fn=die_with_parent) as broker:
        if observer:
            observer("broker", {"url": broker.url, "pid": broker.pid})
        yield broker.url, broker


class _Coordinator:
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
        self.num_workers = workers
        self.external_writers = writers
        self.writer_ids = list(writers) if writers else [LOCAL_WRITER_ID]
        self.observer = observer or (lambda event, details: None)
        self.on_progress = on_progress
        self.executor_name, self.executor_options = executor, executor_options or {}
        self.executor = None  # made in run(), once the broker URL is known
        self.workers: dict[int, int] = {}  # live worker id -> samples it has published
        self.retiring: set[int] = set()
        self.next_worker_id = 0
        self.writer: subprocess.Popen | None = None
        self.restarts = {"worker": 0, "writer": 0, "broker": 0}
        self.acks: deque[int] = deque()
        self.result = BuildResult(out_dir, 0, 0.0)

    # --- the run -------------------------------------------------------------------------------
    def run(self, url: str, broker: ManagedBroker | None) -> None:
        self.url, self.broker = url, broker
        spec = WorkerSpec(self.config.to_dict(), url, self.build_id, self.secret)
        self.executor = make_executor(self.executor_name, spec, self.executor_options)
        total = self.config.num_samples
        with AckCollector(url, self.build_id, on_ack=self.acks.append) as collector:
            self.collector = collector
            try:
                if self.external_writers is None:
                    self._start_writer()
                self._wait_writers_ready()
                if self.external_writers is not None:
                    # writers started earlier re-announce what is durable; ours did before "ready"
                    collector.announce(self.writer_ids, timeout_s=WRITER_READY_TIMEOUT_S)
                durable = {i for i in collector.acked if 0 <= i < total}
                self.result.resumed_from = len(durable)
                self.schedule = Schedule(
                    set(range(total)) - durable, self.config.transfer.ack_timeout_s
                )
                self.acks.clear()
                self._report(total - len(self.schedule.remaining))
                for _ in range(self.num_workers if not self.schedule.done else 0):
                    self._start_worker()
                self._drive()
                manifest = build_manifest(self.config, self.build_id, self.num_workers)
                status = collector.finalize(
                    total, manifest, writers=self.writer_ids, timeout_s=FINALIZE_TIMEOUT_S
                )
                if status.get("state") != "finalized":
                    raise BuildError(
                        f"the writers could not finalize the dataset: {status.get('reason', status)}"
                    )
                self._stop_workers(graceful=True)
                if self.writer is not None:
                    self.writer.wait(timeout=30)
            finally:
                self._stop_workers(graceful=False)
                self._stop_writer()
        self.result.samples = total
        self.result.reissued = self.schedule.reissued
        self.result.restarts = dict(self.restarts)

    def _drive(self) -> None:
        total = self.config.num_samples
        while True:
            while self.acks:
                index = self.acks.popleft()
                if 0 <= index < total:
                    self.schedule.on_acked(index)
            self._report(total - len(self.schedule.remaining))
            if self.schedule.done:
                return
            self._supervise_broker()
            self._supervise_writer()
            self._handle_worker_messages()
            now = time.monotonic()
            overdue = self.schedule.reissue_overdue(now)
            if overdue:
                log.warning(
                    "%d samples not durable %.0f s after publishing; issuing them again: %s",
                    len(overdue),
                    self.config.transfer.ack_timeout_s,
                    overdue[:10],
                )
            for worker_id in list(self.workers):
                self._feed(worker_id)

    def _report(self, done: int) -> None:
        if self.on_progress:
            self.on_progress(done, self.config.num_samples)

    # --- workers ---------------------------------------------------------------------------------
    def _start_worker(self) -> None:
        worker_id = self.next_worker_id
        self.next_worker_id += 1
        details = self.executor.start(worker_id)
        self.workers[worker_id] = 0
        self.schedule.add_worker(worker_id)
        self.observer("worker", {"id": worker_id, **details})
        self._feed(worker_id)

    def _feed(self, worker_id: int) -> None:
        if worker_id in self.retiring:
            return
        for index in self.schedule.next_for(worker_id):
            if not self.executor.send(worker_id, index):
                return  # it died; poll reports it

    def _handle_worker_messages(self) -> None:
        recycle_after = self.config.executor.recycle_after
        for worker_id, kind, payload in self.executor.poll(POLL_S):
            if kind == "published":
                self.schedule.on_published(worker_id, payload, time.monotonic())
                self.workers[worker_id] += 1
                if recycle_after and self.workers[worker_id] >= recycle_after:
                    self._retire(worker_id)
            elif kind == "error":
                raise BuildError(payload)
            elif kind == "lost":
                self._lose_worker(worker_id, payload)
            elif kind == "done":
                self.workers.pop(worker_id, None)
                if worker_id in self.retiring:  # recycled: published samples stay tracked
                    self.retiring.discard(worker_id)
                    self.schedule.on_worker_lost(worker_id, keep_published=True)
                    if not self.schedule.done:
                        self._start_worker()

    def _retire(self, worker_id: int) -> None:
        """Recycling: the worker finishes what it holds and stops; a fresh one replaces it."""
        if worker_id not in self.retiring:
            self.retiring.add(worker_id)
            self.observer("recycle", {"id": worker_id, "samples": self.workers[worker_id]})
            self.executor.retire(worker_id)

    def _lose_worker(self, worker_id: int, why: str) -> None:
        self.workers.pop(worker_id, None)
        self.retiring.discard(worker_id)
        lost = self.schedule.on_worker_lost(worker_id)
        self.restarts["worker"] += 1
        log.warning(
            "worker %d died (%s); issuing its %d unfinished samples again and starting a new worker",
            worker_id,
            why,
            len(lost),
        )
        self.observer("restart", {"what": "worker", "id": worker_id, "reissued": lost})
        if self.restarts["worker"] > MAX_RESTARTS * max(1, self.num_workers):
            raise BuildError(self._missing("workers keep dying"))
        self._start_worker()

    def _stop_workers(self, graceful: bool) -> None:
        if self.executor is not None:
            self.executor.stop(graceful)
        self.workers.clear()

    # --- writer (local) and broker (managed) ------------------------------------------------------
    def _start_writer(self) -> None:
        max_bytes = int(self.config.transfer.max_sample_mb * 2**20) + 2**16
        command = [
            sys.executable, "-m", "datagen.sinks.writer",
            "--build-id", self.build_id,
            "--out", str(self.out_dir),
            "--writer-id", LOCAL_WRITER_ID,
            "--shard-size", str(self.config.output.shard_size),
            "--max-message-bytes", str(max_bytes),
            # a dead writer's session holds its share only until re-issue would cover it anyway
            "--session-expiry", str(round(self.config.transfer.ack_timeout_s)),
            "--log-level", os.environ.get("DATAGEN_LOG_LEVEL", "WARNING"),
        ]  # fmt: skip
        # the broker URL carries the build's password: the environment, not argv, carries it;
        # own session: a terminal's Ctrl-C reaches only the coordinator, which stops the writer
        self.writer = subprocess.Popen(
            command,
            env=os.environ | {"DATAGEN_BROKER_URL": self.url, SECRET_ENV: self.secret.hex()},
            start_new_session=True,
            preexec_fn=die_with_parent,
        )
        self.observer("writer", {"id": LOCAL_WRITER_ID, "pid": self.writer.pid})

    def _wait_writers_ready(self) -> None:
        for writer_id in self.writer_ids:
            deadline = time.monotonic() + WRITER_READY_TIMEOUT_S
            while True:
                if self.writer is not None and self.writer.poll() is not None:
                    raise BuildError(
                        f"the dataset writer exited with code {self.writer.returncode} before it was ready"
                    )
                with contextlib.suppress(TimeoutError):
                    self.collector.wait_status("ready", writer=writer_id, timeout_s=0.5)
                    break
                if time.monotonic() > deadline:
                    raise BuildError(
                        f"writer {writer_id!r} is not ready on the broker after "
                        f"{WRITER_READY_TIMEOUT_S:.0f} s; start it with: datagen writer --broker URL "
                        f"--build-id {self.build_id} --writer-id {writer_id} --out DIR"
                    )

    def _supervise_writer(self) -> None:
        if self.writer is None or self.writer.poll() is None:
            return
        self.restarts["writer"] += 1
        if self.restarts["writer"] > MAX_RESTARTS:
            raise BuildError(
                self._missing(f"the writer keeps dying (exit code {self.writer.returncode})")
            )
        log.warning(
            "the dataset writer exited with code %s; starting it again", self.writer.returncode
        )
        self.observer("restart", {"what": "writer", "exit_code": self.writer.returncode})
        self._start_writer()

    def _supervise_broker(self) -> None:
        if self.broker is None or self.broker.running:
            return
        self.restarts["broker"] += 1
        if self.restarts["broker"] > MAX_RESTARTS:
            raise BuildError(self._missing("the broker keeps dying"))
        log.warning("the broker stopped; starting it again on the same port with its saved state")
        self.observer("restart", {"what": "broker"})
        self.broker.start()
        self.observer("broker", {"url": self.broker.url, "pid": self.broker.pid})

    def _stop_writer(self) -> None:
        if self.writer is None or self.writer.poll() is not None:
            return
        self.writer.terminate()
        try:
            self.writer.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.writer.kill()

    def _missing(self, reason: str) -> str:
        missing = sorted(self.schedule.remaining)
        total = self.config.num_samples
        shown = ", ".join(map(str, missing[:20])) + (" ..." if len(missing) > 20 else "")
        return f"{reason}; {len(missing)} of {total} samples are not durable: {shown}"
