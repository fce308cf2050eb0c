"""A scene worker process: sample indices in over its pipe, rendered samples out over MQTT.

Each worker has its own duplex pipe to the coordinator (not a queue shared by all workers: a
worker killed while reading a shared queue would leave its lock held and stall the others).
Messages to the worker: a :class:`~datagen.pipeline.production.Task`, or ``None`` to finish. From
the worker: ``("heartbeat", None)`` every ``HEARTBEAT_S`` from a thread of its own, from the
moment it starts (the coordinator kills a worker silent for ``build.worker_timeout_s``),
``("ready", None)`` once its start-up (``warm_up``: the renderer, the scene family's imports,
its first frame; the broker connection) is over,
``("started", {"index", "attempt", "failures"})`` as each attempt at a sample begins (one that
runs past ``build.sample_timeout_s`` gets the worker killed), ``("published", index)`` once the
broker has the sample, ``("retried", {"index", "attempt", "failures"})`` before that when the
sample needed retries, ``("failed", {"index", "failures"})`` when every attempt allowed by
``build.on_sample_error: retry`` failed (the worker goes on with its next index), ``("done",
None)``, ``("error", text)`` (the build cannot go on); before ``published``, ``("outcome",
{...})`` when the sample is a grasp attempt or a navigation episode (``live_preview``); at most
once a second an annotated preview goes to the monitors over MQTT.
"""

from __future__ import annotations

import ctypes
import json
import logging
import os
import signal
import threading
import time
import traceback
from multiprocessing.connection import Connection
from typing import Any

from datagen.config import config_from_dict
from datagen.pipeline.live_preview import PreviewFeed, sample_outcome
from datagen.pipeline.production import SampleFailed, Task, produce_with_policy
from datagen.pipeline.warm_up import warm_up
from datagen.records import WorkerEventKind, WorkerPayload
from datagen.sensing.stage_clock import take
from datagen.transport.publisher import SampleTooLarge
from datagen.transport.run_binding import RunBinding, client_id
from datagen.transport.sample_routes import RoutedPublisher

log = logging.getLogger(__name__)
_PR_SET_PDEATHSIG = 1
STAGE_LOG_ENV = "DATAGEN_STAGE_LOG"  # a file: one JSON line of stage timings per sample
HEARTBEAT_S = 2.0


class Channel:
    """The worker's end of its pipe. Two threads send on it (the worker and its heartbeat), so
    sends take a lock: two messages written at once would interleave on the pipe."""

    def __init__(self, conn: Connection):
        self.conn = conn
        self._lock = threading.Lock()
        self._stop = threading.Event()

    def send(self, kind: WorkerEventKind, payload: WorkerPayload) -> None:
        with self._lock:
            self.conn.send((kind, payload))

    def recv(self) -> Task | None:
        return self.conn.recv()

    def start_heartbeat(self) -> None:
        threading.Thread(target=self._beat, name="heartbeat", daemon=True).start()

    def stop_heartbeat(self) -> None:
        self._stop.set()

    def _beat(self) -> None:
        # Needs the GIL: a C call that holds it (SAPIEN's first frame: ~3.5 s on lavapipe)
        # delays the next beat; build.worker_timeout_s must be well above that.
        while True:
            try:
                self.send("heartbeat", None)
            except (OSError, EOFError):  # the coordinator is gone, or closed our pipe
                return
            if self._stop.wait(HEARTBEAT_S):
                return


def _log_stages(path: str, worker_id: int, index: int, timings: dict, sample) -> None:
    record = {"worker": worker_id, "index": index, "bytes": sum(map(len, sample.parts.values()))}
    with open(path, "a", encoding="utf-8") as f:  # one short write per line: appends interleave
        f.write(json.dumps(record | timings) + "\n")


def die_with_parent(sig: int = signal.SIGKILL) -> None:
    """Linux: have the kernel send ``sig`` to this process when its parent dies, so nothing
    of a build outlives a coordinator that was killed (its resume starts them afresh)."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, sig)
    except OSError:
        log.debug("prctl unavailable: this process will not follow its parent's death")


def worker_main(
    worker_id: int,
    config_dict: dict[str, Any],
    broker_url: str,
    sample_urls: tuple[str, ...],
    build_id: str,
    secret: bytes,
    run: RunBinding,
    conn: Connection,
) -> None:
    """Runs in a spawned process until the coordinator sends ``None`` or the pipe closes.
    Samples go to ``sample_urls`` (one broker each by index); previews to ``broker_url``."""
    die_with_parent()
    # Ctrl-C is the coordinator's to handle: it stops the workers itself, in order
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    channel = Channel(conn)
    channel.start_heartbeat()  # before anything slow: start-up is watched too
    logging.basicConfig(
        level=os.environ.get("DATAGEN_LOG_LEVEL", "WARNING"),
        format=f"[worker {worker_id}] %(levelname)s %(message)s",
    )
    task = None
    try:
        config = config_from_dict(config_dict)
        warm_up(config)  # start-up, not the first sample's time (build.sample_timeout_s)
        with RoutedPublisher(
            sample_urls,
            build_id,
            client_id=client_id(build_id, f"worker-{worker_id}"),
            window=config.transfer.window,
            max_message_bytes=int(config.transfer.max_sample_mb * 2**20),
            secret=secret,
            run=run,
        ) as publisher:
            stage_log = os.environ.get(STAGE_LOG_ENV)
            previews = PreviewFeed(broker_url, build_id, str(worker_id))
            channel.send("ready", None)
            while (task := channel.recv()) is not None:
                index = task.index
                take()  # what a failed sample left behind is not this sample's
                start = time.perf_counter()

                def started(attempt: int, failures: list[str], index: int = index) -> None:
                    channel.send(
                        "started", {"index": index, "attempt": attempt, "failures": failures}
                    )

                try:
                    produced = produce_with_policy(config, task, on_attempt=started)
                except SampleFailed as exc:
                    if config.build.on_sample_error != "retry":
                        raise
                    channel.send("failed", {"index": index, "failures": exc.failures})
                    continue
                timings = take()  # seconds per stage within produce: encode_s, ...
                # what no stage timer covers: scene sampling, annotation, Python glue
                timings["other_s"] = time.perf_counter() - start - sum(timings.values())
                start = time.perf_counter()
                publisher.publish(produced.sample)
                timings["publish_s"] = time.perf_counter() - start
                if stage_log:
                    _log_stages(stage_log, worker_id, index, timings, produced.sample)
                if (outcome := sample_outcome(produced.sample)) is not None:
                    channel.send("outcome", outcome)
                if produced.failures:
                    channel.send(
                        "retried",
                        {
                            "index": index,
                            "attempt": produced.attempt,
                            "failures": produced.failures,
                        },
                    )
                channel.send("published", index)
                previews.offer(produced.sample)  # after: the coordinator need not wait for it
            previews.close()
        channel.stop_heartbeat()
        channel.send("done", None)
    except (EOFError, BrokenPipeError):
        pass  # the coordinator is gone
    except SampleTooLarge as exc:
        channel.send("error", f"{exc} (raise transfer.max_sample_mb in the config to allow it)")
        raise SystemExit(1) from None
    except SampleFailed as exc:
        channel.send("error", f"worker {worker_id}: {exc} (build.on_sample_error: fail)")
        raise SystemExit(1) from None
    except Exception:
        where = f"sample {task.index}" if task is not None else "start-up"
        channel.send("error", f"worker {worker_id} failed at {where}:\n{traceback.format_exc()}")
        raise SystemExit(1) from None
