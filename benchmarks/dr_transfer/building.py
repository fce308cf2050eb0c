"""One set built by the real pipeline (``run_build``: workers, MQTT, writer, shards) into a
folder of its own, continued where an earlier run left it."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

PROGRESS_EVERY_S = 60.0  # a line at most this often on a long build


@dataclass
class BuildTime:
    seconds: float  # the whole build: start-up, every sample, finalising
    first_sample_s: float  # until this build's first sample was durable (start-up included)
    steady_s_per_frame: float | None  # between the first durable sample and the last, per sample


def build(source: str, data: dict, out: Path, workers: int) -> BuildTime | None:
    """Builds config dict ``data`` (``source`` names it in errors) into ``out``; what it took,
    or None when ``out`` already held this build, finished. A build interrupted there is
    resumed. A long build prints how far it is, a line a minute."""
    from datagen.config import config_from_dict
    from datagen.pipeline.out_dir import BUILD_STATE
    from datagen.pipeline.run import run_build

    config = config_from_dict(data, source=source)
    start = time.perf_counter()
    durable: list[tuple[int, float]] = []  # (samples durable, seconds since start)
    last_line = start

    def on_progress(done: int, total: int) -> None:
        nonlocal last_line
        now = time.perf_counter()
        durable.append((done, now - start))
        if now - last_line >= PROGRESS_EVERY_S and done < total:
            last_line = now
            print(f"    {done}/{total} durable after {now - start:.0f} s", flush=True)

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
