"""Attempts/s of the grasp samplers side by side: the antipodal sampler and the learned one (a
model file), each with and without ``campaign.check_reach``, on the same held-out-object scenes,
run in turn ``--repeats`` times.

    .venv/bin/python benchmarks/grasp_speed.py --model MODEL.onnx [--arm panda] [--repeats 3]

A campaign's attempts/s measured once, minutes apart from another's, moves with the machine:
on a shared 2-core host the same campaign (same code, same outcome for every attempt) ran at
0.96 attempts/s one day and 0.66 the next. Here the samplers take turns, so a drift slows each alike: printed
are each sampler's attempts/s (mean ± standard error over the repeats, from the first durable
attempt to the last) and its ratio to the antipodal sampler's within each repeat (mean ±
standard error), the figure the learned sampler's speed target is stated in. The scenes are
``benchmarks/grasp_learning.py``'s held-out objects (seed 1000), with its camera size; every
campaign is built in a temporary folder and removed.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

from dr_transfer.building import build
from dr_transfer.hardware import commit
from grasp_learning import EVAL_SEED, campaign_data
from machine import cpu_model

REPO = Path(__file__).resolve().parents[1]
SAMPLERS = ("antipodal", "learned", "antipodal-reach", "learned-reach")
BASE = "antipodal"


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, required=True, help="the learned sampler's model")
    parser.add_argument("--arm", default="panda", help="robot (panda)")
    parser.add_argument("--attempts", type=int, default=30, help="attempts per campaign (30)")
    parser.add_argument("--repeats", type=int, default=3, help="turns of every sampler (3)")
    parser.add_argument("--size", default="320x240", help="camera width x height (320x240)")
    parser.add_argument("--candidates", type=int, default=16, help="K, candidates scored (16)")
    parser.add_argument("--workers", type=int, default=2, help="campaign workers (2)")
    parser.add_argument(
        "--samplers", nargs="+", choices=SAMPLERS, default=list(SAMPLERS), help="(all four)"
    )
    args = parser.parse_args()
    args.samplers = [BASE] + [s for s in args.samplers if s != BASE]  # the ratios' base first
    return args


def attempts_per_s(sampler: str, args) -> float:
    """One campaign of ``sampler`` on the held-out objects, built in a temporary folder."""
    model = args.model.resolve() if sampler.startswith("learned") else None
    reach = sampler.endswith("-reach")
    data = campaign_data(args, args.arm, EVAL_SEED, args.attempts, "objects", model, reach)
    out = Path(tempfile.mkdtemp(prefix="datagen-grasp-speed-"))
    try:
        built = build(f"grasp_speed:{sampler}", data, out / "campaign", args.workers)
    finally:
        shutil.rmtree(out, ignore_errors=True)
    if built is None or built.steady_s_per_frame is None:
        raise SystemExit(f"{sampler}: too few attempts to time ({args.attempts}); ask for more")
    return 1 / built.steady_s_per_frame


def mean_se(values: list[float]) -> tuple[float, float]:
    """Mean and its standard error (nan for a single value)."""
    se = statistics.stdev(values) / math.sqrt(len(values)) if len(values) > 1 else math.nan
    return statistics.fmean(values), se


def summary(rates: dict[str, list[float]]) -> list[str]:
    """Per sampler: attempts/s and the ratio to the antipodal sampler's in the same repeat."""
    lines = []
    for sampler, values in rates.items():
        rate, rate_se = mean_se(values)
        ratios = [v / b for v, b in zip(values, rates[BASE], strict=True)]
        ratio, ratio_se = mean_se(ratios)
        lines.append(
            f"  {sampler:16} {rate:.3f} ± {rate_se:.3f} attempts/s   "
            f"÷ {BASE} {ratio:.2f} ± {ratio_se:.2f}   "
            f"(repeats: {', '.join(f'{v:.3f}' for v in values)})"
        )
    return lines


def main() -> int:
    args = arguments()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    print(
        f"{cpu_model()}, {len(os.sched_getaffinity(0))} cores; benchmarks/grasp_speed.py "
        f"{' '.join(sys.argv[1:])}; commit {commit(REPO)}",
        flush=True,
    )
    rates: dict[str, list[float]] = {sampler: [] for sampler in args.samplers}
    for repeat in range(1, args.repeats + 1):
        for sampler in args.samplers:
            rates[sampler].append(attempts_per_s(sampler, args))
            print(f"  repeat {repeat}: {sampler} {rates[sampler][-1]:.3f} attempts/s", flush=True)
    print(
        f"{args.arm}, held-out objects, {args.attempts} attempts a campaign, K {args.candidates}, "
        f"{args.repeats} repeats:"
    )
    print("\n".join(summary(rates)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
