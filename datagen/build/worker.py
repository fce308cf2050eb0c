"""A scene worker process: sample indices in over its pipe, rendered samples out over MQTT.

Each worker has its own duplex pipe to the coordinator (not a queue shared by all workers: a
worker killed while reading a shared queue would leave its lock held and stall the others).
Messages to the worker: an index, or ``None`` to finish. From the worker:
``("published", index)`` once the broker has the sample, ``("retried", {"index", "attempt",
"failures"})`` before that when the sample needed retries, ``("failed", {"index", "failures"})``
when every attempt allowed by ``build.on_sample_error: retry`` failed (the worker goes on with
its next index), ``("done", None)``, ``("error", text)`` (the build cannot go on).
"""

from __future__ import annotations

import ctypes
import json
import logging
import os
import signal
import time
import traceback
from multiprocessing.connection import Connection
from typing import Any

from datagen.build.production import SampleFailed, produce_with_policy
from datagen.config import config_from_dict
from datagen.engines.sim.stage_clock import take
from datagen.engines.transfer.publisher import SamplePublisher, SampleTooLarge

log = logging.getLogger(__name__)
_PR_SET_PDEATHSIG = 1
STAGE_LOG_ENV = "DATAGEN_STAGE_LOG"  # a file: one JSON line of stage timings per sample


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
    build_id: str,
    secret: bytes,
    conn: Connection,
) -> None:
    """Runs in a spawned process until the coordinator sends ``None`` or the pipe closes."""
    die_with_parent()
    # Ctrl-C is the coordinator's to handle: it stops the workers itself, in order
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.basicConfig(
        level=os.environ.get("DATAGEN_LOG_LEVEL", "WARNING"),
        format=f"[worker {worker_id}] %(levelname)s %(message)s",
    )
    index = None
    try:
        config = config_from_dict(config_dict)
        with SamplePublisher(
            broker_url,
            build_id,
            client_id=f"datagen-{build_id}-worker-{worker_id}",
            window=config.transfer.window,
            max_message_bytes=int(config.transfer.max_sample_mb * 2**20),
            secret=secret,
        ) as publisher:
            stage_log = os.environ.get(STAGE_LOG_ENV)
            while (index := conn.recv()) is not None:
                take()  # what a failed sample left behind is not this sample's
                start = time.perf_counter()
                try:
                    produced = produce_with_policy(config, index)
                except SampleFailed as exc:
                    if config.build.on_sample_error != "retry":
                        raise
                    conn.send(("failed", {"index": index, "failures": exc.failures}))
                    continue
                timings = take()  # seconds per stage within produce: encode_s, ...
                timings["render_s"] = time.perf_counter() - start - sum(timings.values())
                start = time.perf_counter()
                publisher.publish(produced.sample)
                timings["publish_s"] = time.perf_counter() - start
                if stage_log:
                    _log_stages(stage_log, worker_id, index, timings, produced.sample)
                if produced.failures:
                    conn.send(("retried", {"index": index, "attempt": produced.attempt, "failures": produced.failures}))  # fmt: skip
                conn.send(("published", index))
        conn.send(("done", None))
    except (EOFError, BrokenPipeError):
        pass  # the coordinator is gone
    except SampleTooLarge as exc:
        conn.send(("error", f"{exc} (raise transfer.max_sample_mb in the config to allow it)"))
        raise SystemExit(1) from None
    except SampleFailed as exc:
        conn.send(("error", f"worker {worker_id}: {exc} (build.on_sample_error: fail)"))
        raise SystemExit(1) from None
    except Exception:
        where = f"sample {index}" if index is not None else "start-up"
        conn.send(("error", f"worker {worker_id} failed at {where}:\n{traceback.format_exc()}"))
        raise SystemExit(1) from None
