"""Grasp campaigns side by side, per arm: antipodal against random on the same scenes, and
attempts/s with the step-by-step recording on and off.

    .venv/bin/python benchmarks/grasp_campaign.py                          # every arm, 40 attempts
    .venv/bin/python benchmarks/grasp_campaign.py --robot iiwa14 --attempts 100
    .venv/bin/python benchmarks/grasp_campaign.py --robot panda --one-worker   # adds 1 -> N scaling

Runs per arm (same config, seed and attempt indices, so the same scenes and the same targets):
random once (its outcomes are a function of the seed), then ``--repeats`` times antipodal with
recording on and off in turn [, antipodal with 1 worker]. Attempts/s are mean ± standard error
over the repeats; success rates carry the binomial standard error over the attempts.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import shutil
import statistics
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


def _mean_se(values: list[float]) -> tuple[float, float]:
    mean = statistics.fmean(values)
    se = statistics.stdev(values) / math.sqrt(len(values)) if len(values) > 1 else float("nan")
    return mean, se


def _success(row: dict, attempts: int) -> str:
    """The success rate with its binomial standard error over the attempts."""
    p = row["success_rate"]
    return f"{p:.1%} ± {math.sqrt(p * (1 - p) / attempts):.1%}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(REPO / "configs/grasp_campaign.yaml"))
    parser.add_argument("--robot", action="append", choices=sorted(ROBOTS), help="repeatable")
    parser.add_argument("--attempts", type=int, default=40)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--repeats", type=int, default=3, help="timed runs, on and off in turn")
    parser.add_argument("--one-worker", action="store_true", help="also antipodal with 1 worker")
    args = parser.parse_args()
    loaded = load_config(args.config).replace(scene="grasp_attempts", num_samples=args.attempts)
    n, repeats = args.workers, max(1, args.repeats)
    table: dict[tuple[str, str], list[dict]] = {}
    for robot in args.robot or sorted(ROBOTS):
        base = loaded.replace(robot=dataclasses.replace(loaded.robot, name=robot))
        # success is a function of (seed, index): the random baseline runs once; the timed
        # runs alternate recording on and off so that both see the same machine load
        runs = [(f"random, recording on, {n} workers", _variant(base, "random", True), n)]
        for _ in range(repeats):
            runs += [
                (f"antipodal, recording on, {n} workers", _variant(base, "antipodal", True), n),
                (f"antipodal, recording off, {n} workers", _variant(base, "antipodal", False), n),
            ]
        if args.one_worker:
            runs += [("antipodal, recording on, 1 worker", _variant(base, "antipodal", True), 1)]
        for name, config, workers in runs:
            print(f"running {robot}: {name} ...", file=sys.stderr)
            table.setdefault((robot, name), []).append(_campaign(config, workers))

    r, c = loaded.render, loaded.campaign
    print(f"command: {' '.join(sys.argv)}")
    print(
        f"machine: {os.cpu_count()} cores; {args.attempts} attempts per run; {r.width}x{r.height}; "
        f"seed {loaded.seed}; recording {c.record_hz} Hz, frames {c.frame_hz} Hz; attempts/s: "
        f"mean ± standard error over the runs; success: ± binomial standard error"
    )
    print("| robot | run | runs | attempts/s | success | failure modes |")
    print("|---|---|---|---|---|---|")
    for (robot, name), rows in table.items():
        outcomes = {json.dumps(row["failure_modes"], sort_keys=True) for row in rows}
        if len(outcomes) > 1:
            print(f"NOT REPRODUCIBLE: {robot} {name}: {sorted(outcomes)}", file=sys.stderr)
            return 1
        mean, se = _mean_se([row["attempts_per_s"] for row in rows])
        modes = ", ".join(f"{k} {v}" for k, v in sorted(rows[0]["failure_modes"].items()))
        rate = f"{mean:.3f} ± {se:.3f}" if len(rows) > 1 else f"{mean:.3f}"
        print(
            f"| {robot} | {name} | {len(rows)} | {rate} | {_success(rows[0], args.attempts)} "
            f"| {modes} |"
        )
    for robot in dict.fromkeys(robot for robot, _ in table):
        on = table[(robot, f"antipodal, recording on, {n} workers")]
        rnd = table[(robot, f"random, recording on, {n} workers")][0]
        off = table[(robot, f"antipodal, recording off, {n} workers")]
        cost = _mean_se(
            [b["attempts_per_s"] / a["attempts_per_s"] for a, b in zip(on, off, strict=True)]
        )
        line = (
            f"{robot}: antipodal vs random success {_success(on[0], args.attempts)} vs "
            f"{_success(rnd, args.attempts)}; recording off/on speed {cost[0]:.3f} ± {cost[1]:.3f}"
        )
        one = table.get((robot, "antipodal, recording on, 1 worker"))
        if one:
            scaling = statistics.fmean(row["attempts_per_s"] for row in on)
            line += f"; scaling 1 -> {n} workers {scaling / one[0]['attempts_per_s']:.2f}x"
        print(line)
    results = REPO / "benchmarks/results"
    results.mkdir(parents=True, exist_ok=True)
    rows = [{"robot": robot, "run": name, "repeats": runs} for (robot, name), runs in table.items()]
    (results / "grasp_campaign.json").write_text(
        json.dumps({"command": " ".join(sys.argv), "runs": rows}, indent=2)
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
