"""The build coordinator: broker, writer and workers for one dataset build, until exactly N
samples are durable, then the manifest.

    coordinator ──indices──► workers ──MQTT samples──► broker ──► writer ──► shards
         ▲                                                          │
         └──────────────── MQTT acks (sample durable) ◄─────────────┘
"""

from __future__ import annotations

import contextlib
import json
import logging
import multiprocessing as mp
import os
import platform
import queue
import secrets
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

from datagen.config import BuildConfig
from datagen.engines.broker import ManagedBroker
from datagen.engines.transfer import AckCollector
from datagen.engines.wire import VERSION as WIRE_VERSION
from datagen.engines.worker import worker_main
from datagen.scenes.grasp_tabletop import CLASSES

log = logging.getLogger(__name__)
MANIFEST = "manifest.json"
DATASET_FORMAT = "datagen.dataset/1"
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


class BuildError(RuntimeError):
    """The build cannot finish; the message says what is missing and why."""


@dataclass
class BuildResult:
    out_dir: Path
    samples: int
    seconds: float
    already_complete: bool = False


ProgressCallback = Callable[[int, int], None]  # (samples durable, samples requested)


def _versions() -> dict[str, str]:
    versions = {"python": platform.python_version(), "platform": platform.platform()}
    for name in _VERSIONED_PACKAGES:
        with contextlib.suppress(metadata.PackageNotFoundError):
            versions[name] = metadata.version(name)
    return versions


def _complete_manifest(out_dir: Path, config: BuildConfig) -> dict[str, Any] | None:
    path = out_dir / MANIFEST
    if not path.is_file():
        return None
    try:
        manifest = json.loads(path.read_text())
    except ValueError:
        return None
    if manifest.get("config") == config.to_dict() and manifest.get("samples") == config.num_samples:
        return manifest
    return None


def prepare_out_dir(out_dir: Path, config: BuildConfig, overwrite: bool) -> bool:
    """Returns True when ``out_dir`` already holds this exact build (nothing to do)."""
    if _complete_manifest(out_dir, config) is not None and not overwrite:
        return True
    if out_dir.exists() and any(out_dir.iterdir()):
        if not overwrite:
            raise BuildError(
                f"{out_dir} is not empty and does not hold a complete build of this config "
                f"(same config, seed and sample count); choose another --out or pass --overwrite"
            )
        shutil.rmtree(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    return False


def build_manifest(config: BuildConfig, build_id: str, workers: int) -> dict[str, Any]:
    return {
        "dataset_format": DATASET_FORMAT,
        "build_id": build_id,
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        "scene": config.scene,
        "seed": config.seed,
        "num_samples": config.num_samples,
        "workers": workers,
        "classes": list(CLASSES),
        "wire_format_version": WIRE_VERSION,
        "config": config.to_dict(),
        "versions": _versions(),
    }


def run_build(
    config: BuildConfig,
    out_dir: str | os.PathLike,
    workers: int,
    overwrite: bool = False,
    on_progress: ProgressCallback | None = None,
) -> BuildResult:
    out_dir = Path(out_dir)
    start = time.monotonic()
    if prepare_out_dir(out_dir, config, overwrite):
        return BuildResult(out_dir, config.num_samples, 0.0, already_complete=True)
    build_id = secrets.token_hex(6)
    max_bytes = int(config.transfer.max_sample_mb * 2**20) + 2**16  # + wire header room
    with (
        ManagedBroker(max_message_bytes=max_bytes) as broker,
        AckCollector(broker.url, build_id) as acks,
    ):
        writer = _start_writer(broker.url, build_id, out_dir, config, max_bytes)
        context = mp.get_context("spawn")  # SAPIEN/Vulkan and paho threads are not fork-safe
        tasks, events = context.Queue(), context.Queue()
        processes: list[mp.Process] = []
        try:
            _wait_writer_ready(acks, writer)
            for index in range(config.num_samples):
                tasks.put(index)
            for _ in range(workers):
                tasks.put(None)
            processes = [
                context.Process(
                    target=worker_main,
                    args=(w, config.to_dict(), broker.url, build_id, tasks, events),
                    name=f"datagen-worker-{w}",
                    daemon=True,
                )
                for w in range(workers)
            ]
            for process in processes:
                process.start()
            _drive(config.num_samples, acks, events, processes, writer, on_progress)
            status = acks.finalize(
                config.num_samples,
                build_manifest(config, build_id, workers),
                timeout_s=FINALIZE_TIMEOUT_S,
            )
            if status.get("state") != "finalized":
                raise BuildError(
                    f"the writer could not finalize the dataset: {status.get('reason', status)}"
                )
            writer.wait(timeout=30)
            for process in processes:
                process.join(timeout=30)
        finally:
            _stop(processes, writer)
    return BuildResult(out_dir, config.num_samples, time.monotonic() - start)


def _start_writer(
    broker_url: str, build_id: str, out_dir: Path, config: BuildConfig, max_message_bytes: int
) -> subprocess.Popen:
    command = [
        sys.executable, "-m", "datagen.sinks.writer",
        "--build-id", build_id,
        "--out", str(out_dir),
        "--shard-size", str(config.output.shard_size),
        "--max-message-bytes", str(max_message_bytes),
        "--log-level", os.environ.get("DATAGEN_LOG_LEVEL", "WARNING"),
    ]  # fmt: skip
    # the broker URL carries the build's password: pass it in the environment, not on argv
    env = os.environ | {"DATAGEN_BROKER_URL": broker_url}
    # its own session: a terminal's Ctrl-C reaches the coordinator, which stops the writer in order
    return subprocess.Popen(command, env=env, start_new_session=True)


def _wait_writer_ready(acks: AckCollector, writer: subprocess.Popen) -> None:
    deadline = time.monotonic() + WRITER_READY_TIMEOUT_S
    while time.monotonic() < deadline:
        if writer.poll() is not None:
            raise BuildError(
                f"the dataset writer exited with code {writer.returncode} before it was ready"
            )
        with contextlib.suppress(TimeoutError):
            acks.wait_status("ready", timeout_s=0.5)
            return
    raise BuildError(f"the dataset writer was not ready within {WRITER_READY_TIMEOUT_S:.0f} s")


def _drive(
    total: int,
    acks: AckCollector,
    events: mp.Queue,
    processes: list[mp.Process],
    writer: subprocess.Popen,
    on_progress: ProgressCallback | None,
) -> None:
    """Waits until ``total`` samples are durable; raises BuildError on any failure."""
    finished: set[int] = set()
    last = -1
    while True:
        acks.wait_acked(min(total, last + 1), timeout_s=0.2)  # wakes at each new ack
        done = acks.count
        if done != last:
            if on_progress:
                on_progress(done, total)
            last = done
        if done >= total:
            return
        while True:
            try:
                kind, worker_id, payload = events.get_nowait()
            except queue.Empty:
                break
            if kind == "error":
                raise BuildError(payload)
            if kind == "done":
                finished.add(worker_id)
        if writer.poll() is not None:
            raise BuildError(
                _missing(f"the dataset writer exited with code {writer.returncode}", acks, total)
            )
        for w, process in enumerate(processes):
            if not process.is_alive() and w not in finished and process.exitcode not in (None, 0):
                raise BuildError(
                    _missing(f"worker {w} died (exit code {process.exitcode})", acks, total)
                )
        if len(finished) == len(processes) and not acks.wait_acked(total, timeout_s=60):
            raise BuildError(
                _missing("all workers finished but acknowledgements stopped", acks, total)
            )


def _missing(reason: str, acks: AckCollector, total: int) -> str:
    missing = sorted(set(range(total)) - acks.acked)
    shown = ", ".join(map(str, missing[:20])) + (" ..." if len(missing) > 20 else "")
    return f"{reason}; {len(missing)} of {total} samples are not durable: {shown}"


def _stop(processes: list[mp.Process], writer: subprocess.Popen) -> None:
    started = [p for p in processes if p.pid is not None]  # a failed start leaves some unstarted
    for process in started:
        if process.is_alive():
            process.terminate()
    for process in started:
        process.join(timeout=10)
        if process.is_alive():
            process.kill()
    if writer.poll() is None:
        writer.terminate()
        try:
            writer.wait(timeout=10)
        except subprocess.TimeoutExpired:
            writer.kill()
