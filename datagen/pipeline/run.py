"""``run_build``: the entry point of a build. It prepares the output directory, starts (or
joins) the broker, lets the :class:`~datagen.pipeline.coordinator.Coordinator` drive workers and
writers until exactly N samples are durable, then adds the family's summary to the manifest and
runs the exports."""

from __future__ import annotations

import contextlib
import json
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from datagen.config import BuildConfig
from datagen.errors import BuildError
from datagen.exports.runner import ExportProgress, run_exports
from datagen.pipeline.coordinator import Coordinator
from datagen.pipeline.out_dir import prepare_out_dir
from datagen.pipeline.result import BuildResult, Observer, ProgressCallback
from datagen.pipeline.worker import die_with_parent
from datagen.registries import FAMILIES
from datagen.registry import resolve
from datagen.shards import MANIFEST, write_json_durably
from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.mosquitto import ManagedBroker


def run_build(
    config: BuildConfig,
    out_dir: str | os.PathLike,
    workers: int,
    overwrite: bool = False,
    on_progress: ProgressCallback | None = None,
    *,
    resume: bool = False,
    broker_url: str | None = None,
    worker_broker_url: str | None = None,
    sample_broker_urls: list[str] | None = None,
    writers: list[str] | None = None,
    build_id: str | None = None,
    observer: Observer | None = None,
    executor: str = "local",
    executor_options: dict[str, Any] | None = None,
    ray_address: str | None = None,
    on_export_progress: ExportProgress | None = None,
    monitor: Callable[[ManagedBroker], None] | None = None,
) -> BuildResult:
    """Builds ``config.num_samples`` samples into ``out_dir``.

    ``broker_url``: an MQTT v5 broker to use instead of starting Mosquitto;
    ``worker_broker_url``: the workers' URL for it, when they have their own user (else
    ``broker_url``). ``sample_broker_urls``: brokers the samples are spread over, sample ``i``
    to the ``i mod len``-th (``datagen.transport.sample_routes``; each with writers of its own,
    all named in ``writers``); commands, acks and status stay on ``broker_url``. ``writers``: ids of
    writers started elsewhere (``datagen writer``) instead of one local writer. ``executor``:
    ``local`` (processes of this machine) or ``ray`` (actors; ``ray_address`` None starts a local
    Ray instance, ``auto`` or ``ray://host:port`` joins a cluster), or ``simulated`` (workers
    that replay recorded samples; ``executor_options``: its options, ``recorded`` first,
    ``datagen.pipeline.executors.simulated``). ``monitor``: called with
    the build's own broker, started with a WebSockets listener for the monitor page.
    """
    out_dir = Path(out_dir)
    start = time.monotonic()
    identity, complete = prepare_out_dir(out_dir, config, overwrite, resume, build_id)
    if complete:
        # finishes an interrupted export, if any
        run_exports(out_dir, config.output.formats, on_progress=on_export_progress)
        return BuildResult(out_dir, config.num_samples, 0.0, already_complete=True)
    if executor == "ray" and ray_address and not broker_url:
        raise BuildError(
            "--executor ray on a cluster needs a broker every node can reach: pass --broker "
            "mqtt://HOST:PORT (see docs/deployment.md, 'Ray cluster')"
        )
    if sample_broker_urls and (not broker_url or len(writers or []) < len(sample_broker_urls)):
        raise BuildError(
            f"{len(sample_broker_urls)} sample brokers need the build's own broker (broker_url) "
            f"and at least one external writer each (writers: {len(writers or [])}), started "
            "with 'datagen writer --sample-broker URL' (docs/scale-out.md, 'Several brokers')"
        )
    if worker_broker_url and not broker_url:
        raise BuildError("worker_broker_url names a user of an external broker: give broker_url")
    options = dict(executor_options or {})
    if executor == "ray":
        options |= {
            "address": ray_address,
            "cpus_per_worker": config.executor.cpus_per_worker,
            "gpus_per_worker": config.executor.gpus_per_worker,
        }
    coordinator = Coordinator(
        config, out_dir, identity, workers, writers, observer, on_progress, executor, options
    )
    with _broker(config, broker_url, observer, monitor) as (url, broker):
        coordinator.run(url, broker, worker_url=worker_broker_url, sample_urls=sample_broker_urls)
    result = coordinator.result
    result.seconds = time.monotonic() - start
    finish = FAMILIES[config.scene].finish
    if finish and (out_dir / MANIFEST).is_file():
        made = result.samples - result.resumed_from
        extra = resolve(finish)(out_dir, made, result.seconds)
        manifest = json.loads((out_dir / MANIFEST).read_text())
        write_json_durably(out_dir, manifest | extra)
    if (out_dir / MANIFEST).is_file():
        run_exports(out_dir, config.output.formats, on_progress=on_export_progress)
    return result


@contextlib.contextmanager
def _broker(
    config: BuildConfig,
    broker_url: str | None,
    observer: Observer | None,
    monitor: Callable[[ManagedBroker], None] | None = None,
) -> Iterator[tuple[str, ManagedBroker | None]]:
    if broker_url:
        yield broker_url, None
        return
    max_bytes = int(config.transfer.max_sample_mb * 2**20) + 2**16  # + wire header room
    settings = BrokerSettings(max_message_bytes=max_bytes, websockets=monitor is not None)
    with ManagedBroker(settings, preexec_fn=die_with_parent) as broker:
        if monitor:
            monitor(broker)
        if observer:
            observer("broker", {"url": broker.url, "pid": broker.pid})
        yield broker.url, broker
