"""Grasp campaigns side by side: antipodal against random on the same scenes, and attempts/s
for 1 and N workers.

    .venv/bin/python benchmarks/grasp_campaign.py                  # 100 attempts per run, 640x480
    .venv/bin/python benchmarks/grasp_campaign.py --attempts 40    # quick

Runs (same config, seed and attempt indices, so the same scenes and the same targets):
  antipodal, N workers | random, N workers | antipodal, 1 worker (attempts/s only)
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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(REPO / "configs/grasp_campaign.yaml"))
    parser.add_argument("--attempts", type=int, default=100)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    args = parser.parse_args()
    base = load_config(args.config).replace(scene="grasp_attempts", num_samples=args.attempts)

    def with_sampler(name):
        return base.replace(campaign=dataclasses.replace(base.campaign, sampler=name))

    runs = {}
    for name, config, workers in (
        (f"antipodal, {args.workers} workers", with_sampler("antipodal"), args.workers),
        (f"random, {args.workers} workers", with_sampler("random"), args.workers),
        ("antipodal, 1 worker", with_sampler("antipodal"), 1),
    ):
        print(f"running {name} ...", file=sys.stderr)
        runs[name] = _campaign(config, workers)

    r = base.render
    print(f"command: {' '.join(sys.argv)}")
    print(
        f"machine: {os.cpu_count()} cores; {args.attempts} attempts per run; {r.width}x{r.height}; seed {base.seed}"
    )
    print(f"{'run':<24} {'attempts/s':>10} {'success':>8}  failure modes")
    for name, row in runs.items():
        print(
            f"{name:<24} {row['attempts_per_s']:>10.3f} {row['success_rate']:>8.1%}  {row['failure_modes']}"
        )
    a, b = runs[f"antipodal, {args.workers} workers"], runs[f"random, {args.workers} workers"]
    print(
        f"antipodal vs random success rate on the same scenes: {a['success_rate']:.1%} vs {b['success_rate']:.1%}"
    )
    one = runs["antipodal, 1 worker"]["attempts_per_s"]
    print(f"scaling 1 -> {args.workers} workers: {a['attempts_per_s'] / one:.2f}x")
    results = REPO / "benchmarks/results"
    results.mkdir(parents=True, exist_ok=True)
    (results / "grasp_campaign.json").write_text(
        json.dumps({"command": " ".join(sys.argv), "runs": runs}, indent=2)
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
