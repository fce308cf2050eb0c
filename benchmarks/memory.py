"""Worker memory over a long build, with worker recycling and without, in one run.

    .venv/bin/python benchmarks/memory.py                    # 5000 frames per run, 160x120
    .venv/bin/python benchmarks/memory.py --frames 1000      # quick

Each run builds the default grasping config (fresh randomised scene per frame) with 2 workers;
a sampler thread reads the resident set size (RSS) of every live worker process every second.
Reported per run: the workers' mean RSS over the first 10 % of the build (after each worker's
first frame) and over the last 10 %, the largest RSS seen, and the number of workers started.
Runs: ``executor.recycle_after`` = the config default (2000) and 0 (never recycled).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

from datagen.config import load_config
from datagen.config.sections import RenderConfig
from datagen.pipeline.run import run_build

REPO = Path(__file__).resolve().parents[1]
MIB = 2**20


def _run(config, workers: int) -> dict:
    pids: set[int] = set()
    progress = {"done": 0}
    samples: list[tuple[float, int, list[int]]] = []  # (time, done, [rss of live workers])
    stop = threading.Event()

    def sampler() -> None:
        while not stop.wait(1.0):
            rss = []
            for pid in list(pids):
                try:
                    rss.append(psutil.Process(pid).memory_info().rss)
                except psutil.Error:
                    pids.discard(pid)
            samples.append((time.monotonic(), progress["done"], rss))

    started = 0

    def observer(kind: str, details: dict) -> None:
        nonlocal started
        if kind == "worker":
            started += 1
            pids.add(details["pid"])

    def on_progress(done: int, total: int) -> None:
        progress["done"] = done

    out = Path(tempfile.mkdtemp(prefix="datagen-memory-"))
    thread = threading.Thread(target=sampler, daemon=True)
    thread.start()
    try:
        start = time.monotonic()
        run_build(config, out, workers, on_progress=on_progress, observer=observer)
        seconds = time.monotonic() - start
    finally:
        stop.set()
        thread.join()
        shutil.rmtree(out, ignore_errors=True)
    n = config.num_samples
    early = [r for _, done, rss in samples if workers <= done <= n * 0.1 for r in rss]
    late = [r for _, done, rss in samples if done >= n * 0.9 for r in rss]
    return {
        "frames": n,
        "seconds": round(seconds, 1),
        "frames_per_s": round(n / seconds, 2),
        "recycle_after": config.executor.recycle_after,
        "workers_started": started,
        "rss_start_mib": round(sum(early) / len(early) / MIB, 1) if early else None,
        "rss_end_mib": round(sum(late) / len(late) / MIB, 1) if late else None,
        "rss_max_mib": round(max(r for _, _, rss in samples for r in rss) / MIB, 1),
        "timeline": [
            (round(t - samples[0][0], 1), d, [round(r / MIB) for r in rss]) for t, d, rss in samples
        ],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=5000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/memory.json"))
    args = parser.parse_args()
    base = load_config(REPO / "configs/grasp_tabletop.yaml")
    base = base.replace(num_samples=args.frames, render=RenderConfig(width=160, height=120))
    rows = {}
    for recycle in (base.executor.recycle_after, 0):
        config = base.replace(executor=dataclasses.replace(base.executor, recycle_after=recycle))
        name = f"recycle_after={recycle}" if recycle else "never recycled"
        rows[name] = _run(config, args.workers)
        r = rows[name]
        print(
            f"{name:20} {r['frames']} frames in {r['seconds']} s ({r['frames_per_s']} f/s), "
            f"workers started {r['workers_started']}, worker RSS start {r['rss_start_mib']} MiB, "
            f"end {r['rss_end_mib']} MiB, max {r['rss_max_mib']} MiB",
            flush=True,
        )
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"command": " ".join(sys.argv), "rows": rows}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
