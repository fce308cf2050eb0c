"""Scaling from 1 to N workers, local processes against Ray actors, and where a frame's time
goes (render, encode, transfer), in one run.

    .venv/bin/python benchmarks/scaling.py                   # 80 frames per run, 640x480
    .venv/bin/python benchmarks/scaling.py --frames 40       # quick

For W = 1..N and each executor, ``run_build`` of the default grasping config. Ray is started
once before the runs (as a cluster would already be running), so its start-up is not charged to
any run. Per run: wall frames/s (start-up included) and steady frames/s (from the W-th to the
last durable frame). The Ray ÷ local ratio uses steady frames/s (target: within 10 %).

Stage shares come from the local runs: each worker logs, per frame, the time spent in scene +
physics + render + annotation (``render``: the family's ``produce`` less encoding), in PNG/JSON
encoding, and in publishing (serialisation, signing, MQTT with its in-flight window), via
``DATAGEN_STAGE_LOG``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import ray

from datagen.config import load_config
from datagen.pipeline.run import run_build
from datagen.pipeline.worker import STAGE_LOG_ENV

REPO = Path(__file__).resolve().parents[1]


def _run(config, workers: int, executor: str, stage_log: Path | None) -> dict:
    times: list[float] = []
    out = Path(tempfile.mkdtemp(prefix="datagen-scaling-"))
    if stage_log:
        os.environ[STAGE_LOG_ENV] = str(stage_log)
    try:
        start = time.monotonic()

        def on_progress(done: int, total: int) -> None:
            while len(times) < done:
                times.append(time.monotonic())

        run_build(config, out, workers, on_progress=on_progress, executor=executor)
        wall = time.monotonic() - start
    finally:
        os.environ.pop(STAGE_LOG_ENV, None)
        shutil.rmtree(out, ignore_errors=True)
    n = config.num_samples
    steady = (n - workers) / (times[-1] - times[workers - 1]) if n > workers else float("nan")
    return {"frames": n, "wall_s": round(wall, 2), "wall_fps": round(n / wall, 3),
            "steady_fps": round(steady, 3)}  # fmt: skip


def _shares(path: Path) -> dict:
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    for r in rows:  # scene + physics + render + annotation: every stage but encode and publish
        stages = [k for k in r if k.endswith("_s") and k not in ("encode_s", "publish_s")]
        r["render_s"] = sum(r.pop(k) for k in stages)
    mean = {
        k: statistics.fmean(r.get(k, 0.0) for r in rows)
        for k in ("render_s", "encode_s", "publish_s")
    }
    total = sum(mean.values())
    return {
        "frames": len(rows),
        "ms_per_frame": {k.removesuffix("_s"): round(v * 1000, 2) for k, v in mean.items()},
        "share": {k.removesuffix("_s"): round(v / total, 4) for k, v in mean.items()},
        "mean_sample_mb": round(statistics.fmean(r["bytes"] for r in rows) / 2**20, 3),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=80)
    parser.add_argument("--max-workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/scaling.json"))
    args = parser.parse_args()
    config = load_config(REPO / "configs/grasp_tabletop.yaml").replace(num_samples=args.frames)
    ray.init(include_dashboard=False, configure_logging=False)
    logs = Path(tempfile.mkdtemp(prefix="datagen-stages-"))
    rows: dict[str, dict] = {}
    print(f"{'executor':8} {'workers':>7} {'wall s':>7} {'wall f/s':>9} {'steady f/s':>10}")
    try:
        for workers in range(1, args.max_workers + 1):
            for executor in ("local", "ray"):
                log = logs / f"{executor}-{workers}.jsonl" if executor == "local" else None
                r = _run(config, workers, executor, log)
                rows[f"{executor}, {workers} workers"] = r
                print(f"{executor:8} {workers:>7} {r['wall_s']:>7.1f} {r['wall_fps']:>9.2f} {r['steady_fps']:>10.2f}", flush=True)  # fmt: skip
    finally:
        ray.shutdown()
    ratios = {
        f"ray / local, {w} workers": round(
            rows[f"ray, {w} workers"]["steady_fps"] / rows[f"local, {w} workers"]["steady_fps"], 3
        )
        for w in range(1, args.max_workers + 1)
    }
    speedup = {
        f"{ex}, {w} workers / 1 worker": round(
            rows[f"{ex}, {w} workers"]["steady_fps"] / rows[f"{ex}, 1 workers"]["steady_fps"], 3
        )
        for ex in ("local", "ray")
        for w in range(1, args.max_workers + 1)
    }
    shares = {f"local, {w} workers": _shares(logs / f"local-{w}.jsonl") for w in range(1, args.max_workers + 1)}  # fmt: skip
    shutil.rmtree(logs, ignore_errors=True)
    for name, value in {**ratios, **speedup}.items():
        print(f"ratio {name}: {value}")
    for name, s in shares.items():
        print(f"stages ({name}): ms/frame {s['ms_per_frame']}, share {s['share']}")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"command": " ".join(sys.argv), "rows": rows, "ratios": ratios, "speedup": speedup, "stages": shares}, indent=2))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
