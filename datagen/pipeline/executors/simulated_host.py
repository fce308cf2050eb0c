"""A process that hosts many simulated workers (:mod:`datagen.pipeline.executors.simulated`).

Each simulated worker is a thread that takes the indices the coordinator issues it, waits a
drawn render time, and publishes a recorded sample re-keyed as that index, signed and framed as
a real worker publishes it; now and then it crashes (reported ``lost``), hangs (falls silent
until the coordinator kills it) or publishes its sample twice (the writers keep one). The
workers of one host share its MQTT connections (:class:`RoutedPublisher` is thread-safe), so the
each broker sees one client per host, not per worker.

Messages from the coordinator, on the host's pipe: ``("start", id)``, ``("task", id, Task)``,
``("retire", id)``, ``("kill", id)``, ``("stop", graceful)``. To it: a list of worker events
``(id, kind, payload)`` with the kinds of :mod:`datagen.pipeline.worker`; heartbeats of every
live, unhung worker go as one list every ``HEARTBEAT_S``.
"""

from __future__ import annotations

import json
import logging
import queue
import signal
import threading
import time
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from datagen.dataset.loader import load
from datagen.pipeline.production import Task
from datagen.pipeline.worker import HEARTBEAT_S, die_with_parent
from datagen.sample import Sample, sample_key
from datagen.seeding import sample_rng
from datagen.sensing.encode import metadata_bytes
from datagen.transport.run_binding import RunBinding, client_id
from datagen.transport.sample_routes import RoutedPublisher

log = logging.getLogger(__name__)
MAX_RECORDED = 64  # distinct recorded samples held in memory; index i publishes i mod R


@dataclass(frozen=True)
class Faults:
    """Per task, drawn once: ``crash`` (the worker dies before publishing), ``hang`` (it stops
    answering, heartbeats too), ``duplicate`` (it publishes its sample twice); probabilities.
    ``render_s``: the render time drawn per task, uniform in [low, high] seconds."""

    render_s: tuple[float, float] = (0.0, 0.0)
    crash: float = 0.0
    hang: float = 0.0
    duplicate: float = 0.0


class RecordedSamples:
    """Up to ``MAX_RECORDED`` samples of a dataset, as their parts' bytes; ``for_index(i)`` is
    recorded sample ``i mod R`` with its metadata's ``index`` and ``key`` made ``i``'s and its
    ``seed`` the build's (``seed``), as the writers check."""

    def __init__(self, root: str | Path, seed: int):
        self.seed = seed
        dataset = load(root)
        try:
            count = min(len(dataset), MAX_RECORDED)
            if count == 0:
                raise ValueError(f"{root}: no samples to replay")
            self.parts = [dataset.raw(i) for i in range(count)]
        finally:
            dataset.close()
        self.metadata = [json.loads(parts["json"]) for parts in self.parts]

    def for_index(self, index: int) -> Sample:
        k = index % len(self.parts)
        metadata = self.metadata[k] | {"index": index, "key": sample_key(index), "seed": self.seed}
        return Sample(index, {**self.parts[k], "json": metadata_bytes(metadata)})


class Host:
    """The simulated workers of one process, and the pipe they report on."""

    def __init__(self, conn: Connection, publisher: RoutedPublisher, recorded, faults, seed):
        self.conn, self.publisher, self.recorded = conn, publisher, recorded
        self.faults, self.seed = faults, seed
        self.queues: dict[int, queue.Queue[Task | None]] = {}
        self.hung: dict[int, threading.Event] = {}  # set when the coordinator kills it
        self.threads: list[threading.Thread] = []
        self._send_lock = threading.Lock()
        self._stopped = threading.Event()

    def emit(self, events: list[tuple[int, str, Any]]) -> None:
        with self._send_lock:
            try:
                self.conn.send(events)
            except (OSError, EOFError):
                self._stopped.set()  # the coordinator is gone

    def start(self, worker_id: int) -> None:
        self.queues[worker_id] = queue.Queue()
        thread = threading.Thread(target=self._work, args=(worker_id,), daemon=True)
        self.threads.append(thread)
        thread.start()

    def kill(self, worker_id: int) -> None:
        if (tasks := self.queues.pop(worker_id, None)) is not None:
            tasks.put(None)
        if (event := self.hung.pop(worker_id, None)) is not None:
            event.set()

    def stop(self, graceful: bool) -> None:
        """Every worker stops; ``graceful``: each finishes what it holds (5 s at most)."""
        for worker_id in list(self.queues):
            self.queues[worker_id].put(None)
        for worker_id in list(self.hung):
            self.kill(worker_id)
        if graceful:
            for thread in self.threads:
                thread.join(timeout=5.0)
        self._stopped.set()

    def heartbeats(self) -> None:
        while not self._stopped.wait(HEARTBEAT_S):
            alive = [w for w in list(self.queues) if w not in self.hung]
            if alive:
                self.emit([(w, "heartbeat", None) for w in alive])

    def _work(self, worker_id: int) -> None:
        tasks = self.queues[worker_id]
        self.emit([(worker_id, "ready", None)])
        while (task := tasks.get()) is not None:
            index = task.index
            started = {"index": index, "attempt": task.attempt, "failures": list(task.failures)}
            self.emit([(worker_id, "started", started)])
            # a draw per (index, worker): a sample re-issued to another worker draws afresh
            rng = sample_rng(self.seed, index, f"simulated.worker{worker_id}", task.attempt)
            time.sleep(float(rng.uniform(*self.faults.render_s)))
            fault = float(rng.random())
            if fault < self.faults.crash:
                self.queues.pop(worker_id, None)
                self.emit([(worker_id, "lost", "simulated crash")])
                return
            if fault < self.faults.crash + self.faults.hang:
                killed = self.hung[worker_id] = threading.Event()
                killed.wait()  # silent until the coordinator kills it
                return
            sample = self.recorded.for_index(index)
            self.publisher.publish(sample)
            if fault < self.faults.crash + self.faults.hang + self.faults.duplicate:
                self.publisher.publish(sample)
            self.emit([(worker_id, "published", index)])
        if self.queues.pop(worker_id, None) is not None:  # retired, not killed
            self.emit([(worker_id, "done", None)])


def host_main(
    host_id: int,
    sample_urls: tuple[str, ...],
    build_id: str,
    secret: bytes,
    run: RunBinding,
    seed: int,
    options: dict[str, Any],
    conn: Connection,
) -> None:
    """Runs in a spawned process until the coordinator sends ``("stop", ...)``."""
    die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    recorded = RecordedSamples(options["recorded"], seed)
    faults = Faults(**options.get("faults", {}))
    with RoutedPublisher(
        sample_urls,
        build_id,
        client_id=client_id(build_id, f"simulated-host-{host_id}"),
        window=int(options["window"]),
        max_message_bytes=int(options["max_message_bytes"]),
        secret=secret,
        run=run,
    ) as publisher:
        host = Host(conn, publisher, recorded, faults, seed)
        threading.Thread(target=host.heartbeats, daemon=True).start()
        while True:
            try:
                message = conn.recv()
            except (EOFError, OSError):
                return
            kind, *rest = message
            if kind == "start":
                host.start(rest[0])
            elif kind == "task":
                if (tasks := host.queues.get(rest[0])) is not None:
                    tasks.put(rest[1])
            elif kind == "retire":
                if (tasks := host.queues.get(rest[0])) is not None:
                    tasks.put(None)
            elif kind == "kill":
                host.kill(rest[0])
            elif kind == "stop":
                host.stop(graceful=rest[0])
                return
