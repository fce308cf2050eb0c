"""One set built by the real pipeline (``run_build``: workers, MQTT, writer, shards) into a
folder of its own, continued where an earlier run left it."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path


@dataclass
class BuildTime:
    seconds: float  # the whole build: start-up, every sample, finalising
    first_sample_s: float  # until this build's first sample was durable (start-up included)
    steady_s_per_frame: float | None  # between the first durable sample and the last, per sample


def build(source: str, data: dict, out: Path, workers: int) -> BuildTime | None:
    """Builds config dict ``data`` (``source`` names it in errors) into ``out``; what it took,
    or None when ``out`` already held this build, finished. A build interrupted there is
    resumed."""
    from datagen.config import config_from_dict
    from datagen.pipeline.out_dir import BUILD_STATE
    from datagen.pipeline.run import run_build

    config = config_from_dict(data, source=source)
    start = time.perf_counter()
    durable: list[tuple[int, float]] = []  # (samples durable, seconds since start)

    def on_progress(done: int, _: int) -> None:
        durable.append((done, time.perf_counter() - start))

    resume = (out / BUILD_STATE).is_file()
    result = run_build(config, out, workers=workers, resume=resume, on_progress=on_progress)
    if result.already_complete:
        return None
    seconds = time.perf_counter() - start
    durable = [(done, s) for done, s in durable if done > result.resumed_from]
    if not durable:
        return BuildTime(seconds, seconds, None)
    (first_done, first_s), (last_done, last_s) = durable[0], durable[-1]
    steady = (last_s - first_s) / (last_done - first_done) if last_done > first_done else None
    return BuildTime(seconds, first_s, steady)
