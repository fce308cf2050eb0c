"""Workers as processes of this machine."""

from __future__ import annotations

import logging
import multiprocessing as mp
import time
from multiprocessing.connection import wait as wait_connections
from typing import Any

from datagen.pipeline.executors.base import (
    STOP_GRACE_S,
    WORKER_ENV_DEFAULTS,
    Event,
    WorkerSpec,
    default_env,
)
from datagen.pipeline.production import Task
from datagen.pipeline.worker import worker_main
from datagen.records import WorkerMessage

log = logging.getLogger(__name__)


class LocalExecutor:
    """Workers as processes of this machine ("spawn": SAPIEN, Vulkan and paho are not
    fork-safe), each with its own duplex pipe (see datagen/pipeline/worker.py)."""

    def __init__(self, spec: WorkerSpec):
        self.spec = spec
        self.context = mp.get_context("spawn")
        self.workers: dict[int, tuple[Any, Any]] = {}  # id -> (process, connection)

    def start(self, worker_id: int) -> dict[str, Any]:
        ours, theirs = self.context.Pipe(duplex=True)
        s = self.spec
        process = self.context.Process(
            target=worker_main,
            args=(
                worker_id,
                s.config,
                s.broker_url,
                s.sample_brokers,
                s.build_id,
                s.secret,
                s.run,
                theirs,
            ),
            name=f"datagen-worker-{worker_id}",
            daemon=True,
        )
        with default_env(WORKER_ENV_DEFAULTS):  # a spawned child reads it at start
            process.start()
        theirs.close()
        self.workers[worker_id] = (process, ours)
        return {"pid": process.pid}

    def send(self, worker_id: int, task: Task | None) -> bool:
        try:
            self.workers[worker_id][1].send(task)
            return True
        except (BrokenPipeError, OSError, KeyError):
            return False  # it died: poll reports it

    def retire(self, worker_id: int) -> None:
        self.send(worker_id, None)

    def poll(self, timeout: float) -> list[Event]:
        by_conn = {conn: wid for wid, (_, conn) in self.workers.items()}
        if not by_conn:
            time.sleep(timeout)
            return []
        events: list[Event] = []
        for conn in wait_connections(list(by_conn), timeout=timeout):
            worker_id = by_conn[conn]
            try:
                message: WorkerMessage = self.workers[worker_id][1].recv()  # from conn
                kind, payload = message
            except (EOFError, OSError):
                process = self._forget(worker_id)
                events.append((worker_id, "lost", f"exit code {process.exitcode}"))
                continue
            if kind == "done":
                self._forget(worker_id)
            events.append((worker_id, kind, payload))
        return events

    def kill(self, worker_id: int) -> None:
        if worker_id in self.workers:
            self.workers[worker_id][0].kill()  # SIGKILL: ends a stopped process too
            self._forget(worker_id)

    def _forget(self, worker_id: int):
        process, conn = self.workers.pop(worker_id)
        process.join(timeout=5)
        conn.close()
        return process

    def stop(self, graceful: bool) -> None:
        if graceful:
            for worker_id in self.workers:
                self.send(worker_id, None)
        deadline = time.monotonic() + (STOP_GRACE_S if graceful else 0)
        for process, conn in self.workers.values():
            process.join(timeout=max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                process.terminate()
                process.join(timeout=10)
            if process.is_alive():
                process.kill()
            conn.close()
        self.workers.clear()
