"""Simulated workers: the coordinator, the broker, the writers, liveness and re-issue driven by
hundreds or thousands of workers that render nothing (``--executor simulated``, or
``run_build(executor="simulated", executor_options=...)``; docs/scale-out.md).

A simulated worker takes the indices it is issued, waits a drawn render time, and publishes a
recorded sample (from ``recorded``, a dataset this machine built) re-keyed as that index,
signed and framed exactly as a real worker's; with the probabilities of ``faults`` it crashes,
hangs or publishes twice. The workers live as threads in ``hosts`` spawned processes, which
share one MQTT connection each (:mod:`datagen.pipeline.executors.simulated_host`). The samples
are real and verified; only their pixels repeat.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing as mp
import time
from multiprocessing.connection import Connection
from multiprocessing.connection import wait as wait_connections
from pathlib import Path
from typing import Any, cast

from datagen.errors import BuildError
from datagen.pipeline.executors.base import STOP_GRACE_S, Event, WorkerSpec
from datagen.pipeline.executors.simulated_host import Faults, host_main
from datagen.pipeline.production import Task

log = logging.getLogger(__name__)


class SimulatedExecutor:
    """``recorded``: a dataset's folder whose samples are replayed; ``faults``: the fields of
    :class:`Faults` (render time and fault probabilities); ``hosts``: processes the workers are
    spread over (worker ``id`` lives in host ``id mod hosts``); ``window``: each host's
    in-flight samples (default ``transfer.window``, a worker's: a host holding 64 samples of
    1.5 MiB in flight per producer buried a one-core broker)."""

    def __init__(
        self,
        spec: WorkerSpec,
        recorded: str | Path | None = None,
        faults: dict[str, Any] | None = None,
        hosts: int = 2,
        window: int | None = None,
    ):
        if recorded is None or not (Path(recorded) / "manifest.json").is_file():
            raise BuildError(
                "the simulated executor replays a finished dataset: pass --replay DATASET "
                f"(executor option 'recorded'); got {str(recorded)[:200]!r}, not a dataset"
            )
        Faults(**(faults or {}))  # a wrong field is an error here, not in a host
        config = spec.config
        options = {
            "recorded": str(recorded),
            "faults": dict(faults or {}),
            "window": window or int(config["transfer"]["window"]),
            "max_message_bytes": int(config["transfer"]["max_sample_mb"] * 2**20),
        }
        context = mp.get_context("spawn")
        self.hosts: list[tuple[Any, Any]] = []  # (process, connection)
        for host_id in range(max(1, hosts)):
            ours, theirs = context.Pipe(duplex=True)
            process = context.Process(
                target=host_main,
                args=(
                    host_id,
                    spec.sample_brokers,
                    spec.build_id,
                    spec.secret,
                    spec.run,
                    int(config["seed"]),
                    options,
                    theirs,
                ),
                name=f"datagen-simulated-host-{host_id}",
                daemon=True,
            )
            process.start()
            theirs.close()
            self.hosts.append((process, ours))
        self.live: set[int] = set()

    def _host(self, worker_id: int):
        return self.hosts[worker_id % len(self.hosts)][1]

    def _send(self, worker_id: int, message: tuple) -> bool:
        try:
            self._host(worker_id).send(message)
            return True
        except (BrokenPipeError, OSError):
            return False

    def start(self, worker_id: int) -> dict[str, Any]:
        self.live.add(worker_id)
        self._send(worker_id, ("start", worker_id))
        host = worker_id % len(self.hosts)
        return {"pid": self.hosts[host][0].pid, "host": host}

    def send(self, worker_id: int, task: Task) -> bool:
        return worker_id in self.live and self._send(worker_id, ("task", worker_id, task))

    def retire(self, worker_id: int) -> None:
        self._send(worker_id, ("retire", worker_id))

    def poll(self, timeout: float) -> list[Event]:
        events: list[Event] = []
        by_conn = {conn: process for process, conn in self.hosts}
        for ready in wait_connections(list(by_conn), timeout=timeout):
            conn = cast(Connection, ready)  # wait() hands back the connections it was given
            try:
                batch: list[Event] = conn.recv()
            except (EOFError, OSError):
                raise BuildError(
                    f"a simulated host died (exit code {by_conn[conn].exitcode})"
                ) from None
            for worker_id, kind, payload in batch:
                if worker_id not in self.live:
                    continue  # killed: nothing more from it
                if kind in ("lost", "done"):
                    self.live.discard(worker_id)
                events.append((worker_id, kind, payload))
        return events

    def kill(self, worker_id: int) -> None:
        self.live.discard(worker_id)
        self._send(worker_id, ("kill", worker_id))

    def stop(self, graceful: bool) -> None:
        for _, conn in self.hosts:
            with contextlib.suppress(BrokenPipeError, OSError):
                conn.send(("stop", graceful))
        deadline = time.monotonic() + (STOP_GRACE_S if graceful else 1.0)
        for process, conn in self.hosts:
            process.join(timeout=max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                process.kill()
                process.join(timeout=5)
            conn.close()
        self.hosts.clear()
        self.live.clear()
