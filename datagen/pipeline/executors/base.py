"""Where scene workers run: the interface every executor offers the coordinator (local spawned
processes and Ray actors are in ``datagen.registries.EXECUTORS``).

The coordinator talks to both through the same six calls and never sees processes or actors:
``start(id)``, ``send(id, task)``, ``retire(id)`` (finish what it holds, then stop), ``poll``
(events ``(id, kind, payload)`` with kind ``heartbeat``, ``ready`` (start-up over), ``started``
(payload: index, attempt, failures), ``published`` (payload: index), ``done``, ``lost`` (it
died; payload: why) or ``error`` (payload: message); see datagen/pipeline/worker.py), ``kill(id)``
(a worker that stopped answering: at once, whatever its state) and ``stop(graceful)``.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass, field
from typing import Any, Protocol

from datagen.pipeline.production import Task
from datagen.records import WorkerEvent
from datagen.transport.run_binding import RunBinding

# The coordinator stops its workers gracefully only once the dataset is finalized: every sample
# is durable then, and a worker still publishing holds a duplicate of a re-issued sample that it
# retries while no writer listens any more (until its publish timeout). Not worth waiting for.
STOP_GRACE_S = 5.0

Event = WorkerEvent  # (worker id, kind, payload); kinds: see datagen/pipeline/worker.py
# One worker per core: OpenMP/BLAS thread pools in each worker would oversubscribe the cores
# (measured: +12-20 % frames/s for a local worker with 1 thread). Ray sets the same itself.
# A value the user exported wins.
WORKER_ENV_DEFAULTS = {"OMP_NUM_THREADS": "1"}


@contextlib.contextmanager
def default_env(defaults: dict[str, str]):
    added = [k for k in defaults if k not in os.environ]
    os.environ.update({k: defaults[k] for k in added})
    try:
        yield
    finally:
        for k in added:
            os.environ.pop(k, None)


@dataclass
class WorkerSpec:
    """What every worker needs: the build's config, broker, identity and run."""

    config: dict[str, Any]
    broker_url: str = field(repr=False)  # holds the workers' password: never printed
    build_id: str
    secret: bytes = field(repr=False)
    run: RunBinding  # the coordinator's run: named in every sample, part of its key
    # brokers the samples are spread over (datagen.transport.sample_routes); () = broker_url
    sample_urls: tuple[str, ...] = field(default=(), repr=False)

    @property
    def sample_brokers(self) -> tuple[str, ...]:
        return self.sample_urls or (self.broker_url,)


class Executor(Protocol):
    """Built as ``Executor(spec, **options)``; options come from ``--ray-address`` and the
    ``executor`` config section."""

    def start(self, worker_id: int) -> dict[str, Any]:
        """Starts a worker; returns details for the observer (pid, actor id)."""

    def send(self, worker_id: int, task: Task) -> bool:
        """Hands it a sample to make; False if the worker is gone (poll reports it)."""

    def retire(self, worker_id: int) -> None:
        """It finishes what it holds, then reports ``done``."""

    def poll(self, timeout: float) -> list[Event]: ...

    def kill(self, worker_id: int) -> None:
        """Ends a worker that stopped answering (stopped, deadlocked, stuck in one sample) at
        once; poll reports nothing more from it."""

    def stop(self, graceful: bool) -> None:
        """Ends every worker; ``graceful``: each finishes its sample first, for at most
        ``STOP_GRACE_S``."""


def worker_env() -> dict[str, str]:
    """Environment a worker on another machine needs from ours (the log level, and
    ``$DATAGEN_LIVE``, previews on or off: everything else travels in its arguments)."""
    return {k: v for k, v in os.environ.items() if k in ("DATAGEN_LOG_LEVEL", "DATAGEN_LIVE")}
