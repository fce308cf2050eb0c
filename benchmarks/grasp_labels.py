"""Labels per CPU-second: a fresh scene per attempt, against several candidates executed in one
settled scene, rebuilt from its (seed, index) for each candidate after the first.

    .venv/bin/python benchmarks/grasp_labels.py --quick    # a minute: 2 scenes, 2 candidates
    .venv/bin/python benchmarks/grasp_labels.py            # panda, 24 scenes, 4 candidates each

A grasp model learns from attempts with a grasp (``no_candidate`` and ``disturbed`` ones teach
nothing: ``datagen.learning.examples``). An executed grasp moves the scene, so a second
candidate needs the settled scene again; a reused PhysX scene does not reproduce, so it is
rebuilt (draw, build, settle) from the same (seed, index), and only the pictures, the target and
the candidate search are paid once. Per scene index, in one process, the CPU seconds
(``time.process_time``: every thread, lavapipe's and PhysX's included) of:

- ``fresh``: the campaign's own attempt (``produce``), one label at most;
- ``rebuilt``: the scene built and observed once, the antipodal sampler's first ``--per-scene``
  candidates (one per contact pair; the first is the fresh attempt's own grasp), each executed
  in a rebuilt scene whose objects must lie exactly where the first build left them.

Printed: CPU milliseconds per step, labels per CPU-second of each way with their ratio (mean ±
standard error over scene indices), how many rebuilt scenes matched the first build, and what
the extra labels are: successes among first and later candidates, and the scenes whose
candidates both held and failed (pairs a model can rank).
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from collections import defaultdict
from contextlib import contextmanager
from pathlib import Path

from dr_transfer.hardware import commit
from grasp_learning import campaign_data
from machine import cpu_model

REPO = Path(__file__).resolve().parents[1]
FULL = {"scenes": 24, "per_scene": 4, "size": "320x240"}
QUICK = {"scenes": 2, "per_scene": 2, "size": "160x120"}
SEED = 1000
TEACHES_NOTHING = ("no_candidate", "disturbed")


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=f"a minute: {QUICK}")
    parser.add_argument("--arm", default="panda", help="robot (panda)")
    parser.add_argument("--scenes", type=int, help=f"scene indices ({FULL['scenes']})")
    parser.add_argument("--per-scene", type=int, help=f"candidates a scene ({FULL['per_scene']})")
    parser.add_argument("--size", help=f"camera width x height ({FULL['size']})")
    args = parser.parse_args()
    for name, value in (QUICK if args.quick else FULL).items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    return args


class StepClock:
    """CPU seconds per named step, summed."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)

    @contextmanager
    def __call__(self, step: str):
        start = time.process_time()
        try:
            yield
        finally:
            self.seconds[step] += time.process_time() - start

    def total(self) -> float:
        return sum(self.seconds.values())


def fresh(config, index: int, clock: StepClock) -> list[str | None]:
    """The campaign's attempt at ``index``: its failure mode (None: success)."""
    from datagen.families.grasp_attempts.produce import produce

    with clock("attempt"):
        sample = produce(config, SEED, index)
    return [sample.metadata["attempt"]["outcome"]["failure_mode"]]


def rebuilt(config, index: int, per_scene: int, clock: StepClock) -> tuple[list, bool]:
    """The first ``per_scene`` candidates of ``index``'s scene, each executed in a rebuild of
    it: their failure modes, and whether every rebuild matched the first build."""
    from datagen.families.grasp_attempts import produce as attempt
    from datagen.families.grasp_attempts.gripper_geometry import gripper_geometry
    from datagen.families.grasp_attempts.samplers import SampleResult
    from datagen.families.grasp_attempts.samplers.antipodal import AntipodalSampler
    from datagen.seeding import sample_rng

    with clock("build"):
        scene = attempt.attempt_scene(config, SEED, index)
    with clock("observe"):
        campaign, pre, target = attempt.observe_attempt(config, SEED, index, 0, scene)
        attempt.to_sample(pre, config.output.png_level)  # stored once, whatever the labels
    with clock("candidates"):
        sampler = AntipodalSampler.from_campaign(campaign, gripper_geometry(scene.spec))
        found, tries, reason = sampler.draw(
            sample_rng(SEED, index, "grasp"),
            *attempt.grasp_problem(scene, target),
            per_scene,
            campaign.sampler_tries,
        )
    settled = poses(scene)
    modes, same = [], True
    for k, candidate in enumerate(found):
        if k:
            with clock("rebuild"):
                scene = attempt.attempt_scene(config, SEED, index)
            same &= poses(scene) == settled
            target = next(o for o in scene.objects if o.instance_id == target.instance_id)
        with clock("execute"):
            outcome = attempt.execute_proposal(
                config, campaign, scene, target, SampleResult(candidate, tries, reason), {}
            )
        modes.append(outcome.failure_mode if not outcome.success else None)
    return modes or ["no_candidate"], same


def poses(scene) -> list[tuple[float, ...]]:
    return [(*o.entity.pose.p, *o.entity.pose.q) for o in scene.objects]


def labels(modes: list[str | None]) -> int:
    return sum(mode not in TEACHES_NOTHING for mode in modes)


def mean_se(values: list[float]) -> tuple[float, float]:
    if len(values) < 2:
        return (values[0] if values else math.nan), math.nan
    return statistics.fmean(values), statistics.stdev(values) / math.sqrt(len(values))


def main() -> None:
    args = arguments()
    from datagen.config import config_from_dict

    command = "benchmarks/grasp_labels.py " + " ".join(sys.argv[1:])
    print(f"{cpu_model()}; {command}; commit {commit(REPO)}", flush=True)
    shape = argparse.Namespace(size=args.size, candidates=args.per_scene)
    config = config_from_dict(campaign_data(shape, args.arm, SEED, args.scenes, None), "labels")
    fresh_clock, rebuilt_clock = StepClock(), StepClock()
    fresh(config, 10**6, StepClock())  # the renderer and caches warmed outside the count
    per_scene: list[tuple[float, float, list, list]] = []
    matched = 0
    for index in range(args.scenes):
        before = fresh_clock.total(), rebuilt_clock.total()
        one = fresh(config, index, fresh_clock)
        many, same = rebuilt(config, index, args.per_scene, rebuilt_clock)
        matched += same
        cost = fresh_clock.total() - before[0], rebuilt_clock.total() - before[1]
        per_scene.append((*cost, one, many))
        print(
            f"  scene {index}: fresh {one} {cost[0]:.2f} CPU-s; "
            f"its candidates {many} {cost[1]:.2f} CPU-s",
            flush=True,
        )
    report(args, fresh_clock, rebuilt_clock, per_scene, matched)


def report(args, fresh_clock, rebuilt_clock, per_scene, matched) -> None:
    n = len(per_scene)
    print(f"{args.arm}, {args.size}, {n} scene indices, up to {args.per_scene} candidates each")
    for name, clock in (("fresh", fresh_clock), ("rebuilt", rebuilt_clock)):
        steps = ", ".join(f"{k} {1000 * v / n:.0f}" for k, v in clock.seconds.items())
        print(f"  {name} CPU ms a scene index: {steps}")
    rates = {}
    for way, column in (("fresh", 0), ("rebuilt", 1)):
        made = [labels(row[2 + column]) for row in per_scene]
        seconds = [row[column] for row in per_scene]
        rates[way] = sum(made) / sum(seconds)
        mean, se = mean_se([m / s for m, s in zip(made, seconds, strict=True)])
        print(
            f"  {way:8}: {sum(made)} labels in {sum(seconds):.1f} CPU-s: "
            f"{rates[way]:.3f} labels per CPU-second (per scene index {mean:.3f} ± {se:.3f})"
        )
    ratios = [
        (labels(many) / b) / (labels(one) / a) for a, b, one, many in per_scene if labels(one)
    ]
    mean, se = mean_se(ratios)
    print(
        f"  rebuilt ÷ fresh: {rates['rebuilt'] / rates['fresh']:.2f} "
        f"(per scene index with a fresh label: {mean:.2f} ± {se:.2f}, n {len(ratios)})"
    )
    print(f"  rebuilt scenes matching the first build: {matched} of {n}")
    agree = sum(row[2][0] == row[3][0] for row in per_scene)
    print(f"  first candidate's label equal to the fresh attempt's: {agree} of {n}")
    first = [row[3][0] for row in per_scene if row[3][0] not in TEACHES_NOTHING]
    later = [m for row in per_scene for m in row[3][1:] if m not in TEACHES_NOTHING]
    for name, modes in (("first candidates", first), ("later candidates", later)):
        held = sum(m is None for m in modes)
        print(f"  {name}: {held} of {len(modes)} held")
    mixed = sum(
        any(m is None for m in row[3]) and any(m not in (None, *TEACHES_NOTHING) for m in row[3])
        for row in per_scene
    )
    print(f"  scenes whose candidates both held and failed: {mixed} of {n}")


if __name__ == "__main__":
    main()
