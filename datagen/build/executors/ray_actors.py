"""Scene workers as Ray actors: ``datagen build --executor ray [--ray-address auto|ray://...]``.

Each actor declares its resources (``executor.cpus_per_worker``, ``executor.gpus_per_worker``:
with a GPU, SAPIEN renders on it) and publishes its samples to the MQTT broker itself, exactly as
a local worker does; Ray only places the actors and carries the sample indices. A method call
per sample: the coordinator keeps a few in flight per actor, so a dead actor loses at most those
(they are issued again, like a local worker's).
"""

from __future__ import annotations

import logging
import os
import time
from typing import Any

import ray
from ray.exceptions import GetTimeoutError, RayActorError, RayTaskError

from datagen.build.executors.base import Event, WorkerSpec, worker_env

log = logging.getLogger(__name__)
CLOSE_TIMEOUT_S = 30.0


class SceneWorker:
    """A Ray actor: produces and publishes samples; constructed on the node Ray chose."""

    def __init__(self, worker_id: int, spec: WorkerSpec):
        from datagen.config import config_from_dict
        from datagen.engines.transfer.publisher import SamplePublisher

        logging.basicConfig(
            level=os.environ.get("DATAGEN_LOG_LEVEL", "WARNING"),
            format=f"[ray worker {worker_id}] %(levelname)s %(message)s",
        )
        self.config = config_from_dict(spec.config)
        self.publisher = SamplePublisher(
            spec.broker_url,
            spec.build_id,
            client_id=f"datagen-{spec.build_id}-ray-{worker_id}",
            window=self.config.transfer.window,
            max_message_bytes=int(self.config.transfer.max_sample_mb * 2**20),
            secret=spec.secret,
        )
        self.publisher.__enter__()

    def produce(self, index: int) -> dict[str, Any]:
        """``{"index", "attempt", "failures", "published"}``; raises if the build must stop."""
        from datagen.build.production import SampleFailed, produce_with_policy

        try:
            produced = produce_with_policy(self.config, index)
        except SampleFailed as exc:
            if self.config.build.on_sample_error != "retry":
                raise
            return {"index": index, "failures": exc.failures, "published": False}
        self.publisher.publish(produced.sample)
        return {"index": index, "attempt": produced.attempt, "failures": produced.failures, "published": True}  # fmt: skip

    def close(self) -> bool:
        """Waits until the broker has everything published, then disconnects."""
        self.publisher.__exit__(None, None, None)
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
        self.actor_class = ray.remote(num_cpus=cpus_per_worker, num_gpus=gpus_per_worker)(
            SceneWorker
        )
        self.actors: dict[int, Any] = {}
        self.pending: dict[Any, tuple[int, str, int | None]] = {}  # ref -> (worker, call, index)
        self.lost: set[int] = set()

    def start(self, worker_id: int) -> dict[str, Any]:
        actor = self.actor_class.options(name=None, max_restarts=0).remote(worker_id, self.spec)
        self.actors[worker_id] = actor
        return {"ray_actor": actor._actor_id.hex()}

    def send(self, worker_id: int, index: int) -> bool:
        actor = self.actors.get(worker_id)
        if actor is None:
            return False
        self.pending[actor.produce.remote(index)] = (worker_id, "produce", index)
        return True

    def retire(self, worker_id: int) -> None:
        actor = self.actors.get(worker_id)
        if actor is not None:
            self.pending[actor.close.remote()] = (worker_id, "close", None)

    def poll(self, timeout: float) -> list[Event]:
        if not self.pending:
            ready = []
            time.sleep(timeout)
        else:
            refs = list(self.pending)
            ray.wait(refs, num_returns=1, timeout=timeout)
            ready, _ = ray.wait(refs, num_returns=len(refs), timeout=0)
        events: list[Event] = []
        for ref in ready:
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
                events.append((worker_id, "error", f"worker {worker_id} failed at sample {index}: {cause}"))  # fmt: skip
                continue
            if call == "produce":
                events.extend((worker_id, kind, payload) for kind, payload in _produced(result))
            else:
                ray.kill(self.actors.pop(worker_id))
                events.append((worker_id, "done", None))
        return events

    def _lose(self, worker_id: int) -> None:
        self.lost.add(worker_id)
        self.actors.pop(worker_id, None)
        for ref in [r for r, (w, _, _) in self.pending.items() if w == worker_id]:
            del self.pending[ref]

    def stop(self, graceful: bool) -> None:
        if graceful:
            closes = [a.close.remote() for a in self.actors.values()]
            try:
                ray.get(closes, timeout=CLOSE_TIMEOUT_S)
            except (GetTimeoutError, RayActorError, RayTaskError) as exc:
                log.warning("Ray workers did not close cleanly: %s", exc)
        for actor in self.actors.values():
            ray.kill(actor)
        self.actors.clear()
        self.pending.clear()
        if self._owns_ray:
            ray.shutdown()


def _produced(result: dict[str, Any]) -> list[tuple[str, Any]]:
    """A produce call's result as the events a local worker sends (see datagen/build/worker.py)."""
    index, failures = result["index"], result["failures"]
    if not result["published"]:
        return [("failed", {"index": index, "failures": failures})]
    retried = [("retried", {"index": index, "attempt": result["attempt"], "failures": failures})]
    return [*(retried if failures else []), ("published", index)]
