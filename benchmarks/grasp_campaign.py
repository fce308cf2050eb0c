"""Grasp campaigns side by side, per arm: antipodal against random on the same scenes, and
attempts/s with the step-by-step recording on and off.

    .venv/bin/python benchmarks/grasp_campaign.py                          # every arm, 40 attempts
    .venv/bin/python benchmarks/grasp_campaign.py --robot iiwa14 --attempts 100
    .venv/bin/python benchmarks/grasp_campaign.py --robot panda --one-worker   # adds 1 -> N scaling

Runs per arm (same config, seed and attempt indices, so the same scenes and the same targets):
  antipodal, recording on | random, recording on | antipodal, recording off [| antipodal, 1 worker]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

from datagen.config import load_config
from datagen.pipeline.run import run_build
from datagen.registries import ROBOTS

REPO = Path(__file__).resolve().parents[1]


def _campaign(config, workers: int) -> dict:
    out = Path(tempfile.mkdtemp(prefix="datagen-campaign-"))
    try:
        start = time.monotonic()
        run_build(config, out, workers)
        seconds = time.monotonic() - start
        stats = json.loads((out / "manifest.json").read_text())["campaign"]
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return {
        "seconds": round(seconds, 2),
        "attempts_per_s": round(config.num_samples / seconds, 3),
        **stats,
    }


def _variant(base, sampler: str, record: bool):
    campaign = dataclasses.replace(base.campaign, sampler=sampler)
    if not record:
        campaign = dataclasses.replace(campaign, record_hz=0, frame_hz=0)
    return base.replace(campaign=campaign)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(REPO / "configs/grasp_campaign.yaml"))
    parser.add_argument("--robot", action="append", choices=sorted(ROBOTS), help="repeatable")
    parser.add_argument("--attempts", type=int, default=40)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--one-worker", action="store_true", help="also antipodal with 1 worker")
    args = parser.parse_args()
    loaded = load_config(args.config).replace(scene="grasp_attempts", num_samples=args.attempts)
    n = args.workers
    table = {}
    for robot in args.robot or sorted(ROBOTS):
        base = loaded.replace(robot=dataclasses.replace(loaded.robot, name=robot))
        runs = {
            f"antipodal, recording on, {n} workers": (_variant(base, "antipodal", True), n),
            f"random, recording on, {n} workers": (_variant(base, "random", True), n),
            f"antipodal, recording off, {n} workers": (_variant(base, "antipodal", False), n),
        }
        if args.one_worker:
            runs["antipodal, recording on, 1 worker"] = (_variant(base, "antipodal", True), 1)
        for name, (config, workers) in runs.items():
            print(f"running {robot}: {name} ...", file=sys.stderr)
            table[(robot, name)] = _campaign(config, workers)

    r, c = loaded.render, loaded.campaign
    print(f"command: {' '.join(sys.argv)}")
    print(
        f"machine: {os.cpu_count()} cores; {args.attempts} attempts per run; {r.width}x{r.height}; "
        f"seed {loaded.seed}; recording {c.record_hz} Hz, frames {c.frame_hz} Hz"
    )
    print("| robot | run | attempts/s | success | failure modes |\n|---|---|---|---|---|")
    for (robot, name), row in table.items():
        modes = ", ".join(f"{k} {v}" for k, v in sorted(row["failure_modes"].items()))
        print(
            f"| {robot} | {name} | {row['attempts_per_s']:.3f} | {row['success_rate']:.1%} | {modes} |"
        )
    for robot in dict.fromkeys(robot for robot, _ in table):
        on = table[(robot, f"antipodal, recording on, {n} workers")]
        rnd = table[(robot, f"random, recording on, {n} workers")]
        off = table[(robot, f"antipodal, recording off, {n} workers")]
        line = (
            f"{robot}: antipodal vs random success {on['success_rate']:.1%} vs "
            f"{rnd['success_rate']:.1%}; recording costs {off['attempts_per_s'] / on['attempts_per_s']:.2f}x"
        )
        one = table.get((robot, "antipodal, recording on, 1 worker"))
        if one:
            line += (
                f"; scaling 1 -> {n} workers {on['attempts_per_s'] / one['attempts_per_s']:.2f}x"
            )
        print(line)
    results = REPO / "benchmarks/results"
    results.mkdir(parents=True, exist_ok=True)
    rows = [{"robot": robot, "run": name, **row} for (robot, name), row in table.items()]
    (results / "grasp_campaign.json").write_text(
        json.dumps({"command": " ".join(sys.argv), "runs": rows}, indent=2)
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
