"""Episode builds: episodes/s and frames/s of the whole pipeline for each shipped episode config
(Fetch in rooms, corridors and mazes; three Fetch robots at once in rooms; the car in the
four-arm maze; drones in corridors, mazes and rooms), and the plain in-process episode loop on the same episodes for comparison.

    .venv/bin/python benchmarks/nav_throughput.py                  # 30 episodes per config
    .venv/bin/python benchmarks/nav_throughput.py --episodes 6     # quick
    .venv/bin/python benchmarks/nav_throughput.py --only aerial_corridor nav_plus_maze_car

Per config (configs/<name>.yaml, same seed and indices on both sides):
  pipeline: run_build with W workers, then with 1 (Mosquitto, writer, manifest), wall time as a
            user sees it, start-up included
  plain:    produce(config, seed, i) in this process, one after another (plan, build
            the scene, render, label, encode; no transfer), after one untimed warm-up episode

"frames" counts rendered images: a frame of every camera. Lavapipe renders with one thread per core, so a single process already keeps both cores of a
2-core machine busy: more workers than that add no render throughput there.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

from datagen.config import load_config
from datagen.dataset.loader import load
from datagen.pipeline.run import run_build
from datagen.registries import FAMILIES

REPO = Path(__file__).resolve().parents[1]
CONFIGS = ("nav_rooms", "nav_corridor", "nav_maze", "nav_plus_maze_car", "nav_rooms_fleet",
           "aerial_corridor", "aerial_maze", "aerial_rooms")  # fmt: skip


def _pipeline(config, workers: int) -> dict:
    out = Path(tempfile.mkdtemp(prefix="datagen-nav-"))
    try:
        start = time.monotonic()
        run_build(config, out, workers)
        seconds = time.monotonic() - start
        dataset = load(out)
        # rendered images: a frame of every camera (an aerial episode has one or more a drone)
        frames = sum(
            n.endswith(".rgb.png") for i in range(len(dataset)) for n in dataset.part_names(i)
        )
        size = sum(p.stat().st_size for p in out.glob("*.tar"))
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return {"seconds": seconds, "frames": frames, "bytes": size}


def _plain(config) -> dict:
    family = FAMILIES[config.scene]
    family.produce_sample(config, config.seed + 1, 0)  # warm-up: shaders, meshes
    start, frames = time.monotonic(), 0
    for i in range(config.num_samples):
        sample = family.produce_sample(config, config.seed, i)
        frames += sum(name.endswith(".rgb.png") for name in sample.parts)
    return {"seconds": time.monotonic() - start, "frames": frames}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=30)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument(
        "--only", nargs="+", choices=CONFIGS, default=list(CONFIGS), metavar="CONFIG"
    )
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/nav_throughput.json"))
    args = parser.parse_args()
    rows = {}
    print(
        f"{'config':18} {'side':22} {'episodes':>8} {'frames':>7} {'s':>7} "
        f"{'episodes/s':>10} {'frames/s':>9} {'MB/episode':>10}"
    )
    for family in args.only:
        config = load_config(REPO / f"configs/{family}.yaml").replace(num_samples=args.episodes)
        for side, run in (
            (f"pipeline, {args.workers} workers", lambda c=config: _pipeline(c, args.workers)),
            ("pipeline, 1 worker", lambda c=config: _pipeline(c, 1)),
            ("plain loop, 1 process", lambda c=config: _plain(c)),
        ):
            r = run()
            row = {
                "episodes": args.episodes,
                "frames": r["frames"],
                "seconds": round(r["seconds"], 2),
                "episodes_per_s": round(args.episodes / r["seconds"], 3),
                "frames_per_s": round(r["frames"] / r["seconds"], 2),
            }
            if "bytes" in r:
                row["mb_per_episode"] = round(r["bytes"] / args.episodes / 2**20, 2)
            rows[f"{family}: {side}"] = row
            print(
                f"{family:18} {side:22} {row['episodes']:>8} {row['frames']:>7} "
                f"{row['seconds']:>7.1f} {row['episodes_per_s']:>10.3f} {row['frames_per_s']:>9.2f} "
                f"{row.get('mb_per_episode', ''):>10}",
                flush=True,
            )
    result = {
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
        "machine": {
            "cores": os.cpu_count(),
            "cpu": platform.processor() or platform.machine(),
            "load_average": os.getloadavg(),
        },
        "runs": rows,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    print(f"results: {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
