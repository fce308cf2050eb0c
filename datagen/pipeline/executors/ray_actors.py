"""Scene workers as Ray actors: ``datagen build --executor ray [--ray-address auto|ray://...]``.

Each actor declares its resources (``executor.cpus_per_worker``, ``executor.gpus_per_worker``:
with a GPU, SAPIEN renders on it) and publishes its samples to the MQTT broker itself, exactly as
a local worker does; Ray only places the actors and carries the sample indices. A method call
per sample: the coordinator keeps a few in flight per actor, so a dead actor loses at most those
(they are issued again, like a local worker's). Liveness: the coordinator's heartbeats are
``ping`` calls, answered on a thread of their own (concurrency group ``liveness``) with what the
actor is working on; an actor that stops answering is ended with ``ray.kill``.
"""

from __future__ import annotations

import logging
import os
import time
from typing import Any

import ray
from ray.exceptions import GetTimeoutError, RayActorError, RayTaskError

from datagen.pipeline.executors.base import STOP_GRACE_S, Event, WorkerSpec, worker_env
from datagen.pipeline.live_preview import PreviewFeed, sample_outcome
from datagen.pipeline.production import Task
from datagen.pipeline.worker import HEARTBEAT_S
from datagen.records import AttemptRecord, ProducedRecord, WorkerMessage

log = logging.getLogger(__name__)


class SceneWorker:
    """A Ray actor: produces and publishes samples; constructed on the node Ray chose."""

    def __init__(self, worker_id: int, spec: WorkerSpec):
        from datagen.config import config_from_dict
        from datagen.pipeline.warm_up import warm_up
        from datagen.transport.run_binding import client_id
        from datagen.transport.sample_routes import RoutedPublisher

        logging.basicConfig(
            level=os.environ.get("DATAGEN_LOG_LEVEL", "WARNING"),
            format=f"[ray worker {worker_id}] %(levelname)s %(message)s",
        )
        self.config = config_from_dict(spec.config)
        warm_up(self.config)  # start-up, not the first sample's time (build.sample_timeout_s)
        self.publisher = RoutedPublisher(
            spec.sample_brokers,
            spec.build_id,
            client_id=client_id(spec.build_id, f"ray-{worker_id}"),
            window=self.config.transfer.window,
            max_message_bytes=int(self.config.transfer.max_sample_mb * 2**20),
            secret=spec.secret,
            run=spec.run,
        )
        self.publisher.__enter__()
        self.previews = PreviewFeed(spec.broker_url, spec.build_id, str(worker_id))
        self.working: AttemptRecord | None = None  # the attempt in progress, for ping

    def produce(self, task: Task) -> ProducedRecord:
        """What became of the sample; raises if the build must stop."""
        from datagen.pipeline.production import SampleFailed, produce_with_policy

        def started(attempt: int, failures: list[str]) -> None:
            self.working = {"index": task.index, "attempt": attempt, "failures": failures}

        index = task.index
        try:
            produced = produce_with_policy(self.config, task, on_attempt=started)
        except SampleFailed as exc:
            self.working = None
            if self.config.build.on_sample_error != "retry":
                raise
            return {"index": index, "failures": exc.failures, "published": False}
        self.publisher.publish(produced.sample)
        self.working = None
        self.previews.offer(produced.sample)
        outcome = sample_outcome(produced.sample)
        return {
            "index": index,
            "attempt": produced.attempt,
            "failures": produced.failures,
            "published": True,
            "outcome": outcome,
        }

    @ray.method(concurrency_group="liveness")
    def ping(self) -> AttemptRecord | None:
        """Runs beside ``produce`` (its own thread): the attempt in progress, if any."""
        return self.working

    def close(self) -> bool:
        """Waits until the broker has everything published, then disconnects."""
        self.publisher.__exit__(None, None, None)
        self.previews.close()
        return True


class RayExecutor:
    def __init__(
        self,
        spec: WorkerSpec,
        address: str | None = None,
        cpus_per_worker: float = 1.0,
        gpus_per_worker: float = 0.0,
    ):
        self.spec = spec
        if not ray.is_initialized():
            ray.init(
                address=address,  # None: a local Ray instance for this build
                include_dashboard=False,
                log_to_driver=True,
                runtime_env={"env_vars": worker_env()},
                configure_logging=False,
            )
            self._owns_ray = True
        else:
            self._owns_ray = False
        self.actor_class = ray.remote(
            num_cpus=cpus_per_worker,
            num_gpus=gpus_per_worker,
            concurrency_groups={"liveness": 1},
        )(SceneWorker)
        self.actors: dict[int, Any] = {}
        self.pending: dict[Any, tuple[int, str, int | None]] = {}  # ref -> (worker, call, index)
        self.lost: set[int] = set()
        self.pinged: dict[int, float] = {}  # worker -> when its last ping was sent
        self.reported: dict[int, tuple[int, int]] = {}  # worker -> (index, attempt) reported

    def start(self, worker_id: int) -> dict[str, Any]:
        actor = self.actor_class.options(name=None, max_restarts=0).remote(worker_id, self.spec)
        self.actors[worker_id] = actor
        return {"ray_actor": actor._actor_id.hex()}

    def send(self, worker_id: int, task: Task) -> bool:
        actor = self.actors.get(worker_id)
        if actor is None:
            return False
        self.pending[actor.produce.remote(task)] = (worker_id, "produce", task.index)
        return True

    def retire(self, worker_id: int) -> None:
        actor = self.actors.get(worker_id)
        if actor is not None:
            self.pending[actor.close.remote()] = (worker_id, "close", None)

    def poll(self, timeout: float) -> list[Event]:
        self._ping()
        refs = list(self.pending)
        if not refs:
            time.sleep(timeout)
            return []
        ray.wait(refs, num_returns=1, timeout=timeout)
        ready, _ = ray.wait(refs, num_returns=len(refs), timeout=0)
        events: list[Event] = []
        # results before pings: a ping must not report an attempt whose result is in
        for ref in sorted(ready, key=lambda r: self.pending[r][1] == "ping"):
            entry = self.pending.pop(ref, None)
            if entry is None or entry[0] in self.lost:  # its worker was already reported lost
                continue
            worker_id, call, index = entry
            try:
                result = ray.get(ref)
            except RayActorError as exc:
                self._lose(worker_id)
                events.append((worker_id, "lost", f"Ray actor died: {exc}"[:500]))
                continue
            except RayTaskError as exc:
                cause = exc.cause if exc.cause is not None else exc
                events.append(
                    (worker_id, "error", f"worker {worker_id} failed at sample {index}: {cause}")
                )
                continue
            if call == "produce":
                events.extend((worker_id, kind, payload) for kind, payload in _produced(result))
            elif call == "ping":
                events.extend(self._pinged(worker_id, result))
            else:
                ray.kill(self.actors.pop(worker_id))
                events.append((worker_id, "done", None))
        return events

    def _ping(self) -> None:
        """Pings every actor with no ping in flight, every HEARTBEAT_S."""
        in_flight = {w for w, call, _ in self.pending.values() if call == "ping"}
        now = time.monotonic()
        for worker_id, actor in self.actors.items():
            if worker_id not in in_flight and now - self.pinged.get(worker_id, 0.0) >= HEARTBEAT_S:
                self.pending[actor.ping.remote()] = (worker_id, "ping", None)
                self.pinged[worker_id] = now

    def _pinged(self, worker_id: int, working: AttemptRecord | None) -> list[Event]:
        # the first answer comes once the constructor (the actor's start-up) is over
        events: list[Event] = [
            (worker_id, "heartbeat" if worker_id in self.reported else "ready", None)
        ]
        self.reported.setdefault(worker_id, (-1, -1))
        held = {i for w, call, i in self.pending.values() if w == worker_id and call == "produce"}
        if working is not None and working["index"] in held:
            attempt = (working["index"], working["attempt"])
            if self.reported.get(worker_id) != attempt:
                self.reported[worker_id] = attempt
                events.append((worker_id, "started", working))
        return events

    def kill(self, worker_id: int) -> None:
        actor = self.actors.get(worker_id)
        self._lose(worker_id)
        if actor is not None:
            ray.kill(actor, no_restart=True)

    def _lose(self, worker_id: int) -> None:
        self.lost.add(worker_id)
        self.actors.pop(worker_id, None)
        for ref in [r for r, (w, _, _) in self.pending.items() if w == worker_id]:
            del self.pending[ref]

    def stop(self, graceful: bool) -> None:
        if graceful:
            closes = [a.close.remote() for a in self.actors.values()]
            try:
                ray.get(closes, timeout=STOP_GRACE_S)
            except (GetTimeoutError, RayActorError, RayTaskError) as exc:
                log.warning("Ray workers did not close cleanly: %s", exc)
        for actor in self.actors.values():
            ray.kill(actor)
        self.actors.clear()
        self.pending.clear()
        if self._owns_ray:
            ray.shutdown()


def _produced(result: ProducedRecord) -> list[WorkerMessage]:
    """A produce call's result as the events a local worker sends (see datagen/pipeline/worker.py)."""
    index, failures = result["index"], result["failures"]
    if not result["published"]:
        return [("failed", {"index": index, "failures": failures})]
    retried: list[WorkerMessage] = [
        ("retried", {"index": index, "attempt": result["attempt"], "failures": failures})
    ]
    outcome: list[WorkerMessage] = [("outcome", result["outcome"])] if result.get("outcome") else []
    return [*outcome, *(retried if failures else []), ("published", index)]
