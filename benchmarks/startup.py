"""Start-up: from the ``datagen build`` command to the first durable sample, now and at an
earlier commit, in one run.

    .venv/bin/python benchmarks/startup.py                    # 5 alternating runs of each side
    .venv/bin/python benchmarks/startup.py --before 0c58188   # against that commit
    .venv/bin/python benchmarks/startup.py --repeat 2 --samples 4   # quick

Each run is the real command, ``datagen build configs/grasp_tabletop.yaml --out TMP
--num-samples N --workers 2 --no-preview`` (default config, 640x480), with progress printed on
every sample (``$DATAGEN_PROGRESS_INTERVAL_S=0``); the script stamps each line as it arrives:

| column | meaning |
|---|---|
| first line s | the command's first output: interpreter, CLI imports, config, output directory |
| writer ready s | ``0/N durable``: broker started, the writer ready and bound to the run |
| first durable s | ``1/N durable``: the first sample rendered, published, written and acknowledged |
| all durable s | ``N/N durable`` |
| wall s | until the command exits (manifest, card, exports) |
| CPU s | user + system CPU of the command and every process it started |

``--before REV`` runs the same command from a git worktree of REV (its ``datagen`` package on
``PYTHONPATH``, this environment's packages), alternating with the current tree. Each side
gets one untimed run first (Mesa's shader cache, the BRDF table cache). Reported: mean ±
standard error over the repeats. ``--worker`` adds a profile of one worker's start-up in a
fresh interpreter (imports, renderer warm-up, the scene family's imports, first and second
sample), for each side. Results: ``benchmarks/results/startup.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CONFIG = "configs/grasp_tabletop.yaml"
PROGRESS = re.compile(r"datagen: (\d+)/(\d+) durable")
COLUMNS = ("first_line_s", "writer_ready_s", "first_durable_s", "all_durable_s", "wall_s", "cpu_s")

# one worker's start-up, step by step, in a fresh interpreter (the tree's datagen on sys.path)
_WORKER_PROFILE = """
import json, sys, time
sys.path.insert(0, {tree!r})
t0 = time.perf_counter(); steps = {{}}
def lap(name):
    global t0
    now = time.perf_counter(); steps[name] = round(now - t0, 3); t0 = now
import datagen.pipeline.worker
from datagen.config import load_config
from datagen.sensing.render import keep_renderer_alive
from datagen.pipeline.production import Task, produce_with_policy
config = load_config({tree!r} + "/{config}")
lap("import worker, config")
keep_renderer_alive()
lap("renderer warm-up")
import datagen.families.grasp_tabletop.produce
lap("scene family imports")
produce_with_policy(config, Task(0))
lap("first sample")
produce_with_policy(config, Task(1))
lap("second sample")
print(json.dumps(steps))
"""


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def one_build(tree: Path, samples: int) -> dict[str, float]:
    """One build with ``tree``'s datagen; seconds from the command's start."""
    out = Path(tempfile.mkdtemp(prefix="startup-"))
    command = [sys.executable, "-m", "datagen.cli", "build", str(tree / CONFIG), "--out",
               str(out / "ds"), "--num-samples", str(samples), "--workers", "2", "--no-preview"]  # fmt: skip
    env = os.environ | {"DATAGEN_PROGRESS_INTERVAL_S": "0", "PYTHONPATH": str(tree)}
    marks: dict[str, float] = {}
    cpu_before = _children_cpu()
    start = time.monotonic()
    with subprocess.Popen(
        command, cwd=tree, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        stdin=subprocess.DEVNULL, text=True,
    ) as process:  # fmt: skip
        assert process.stdout is not None
        lines = []
        for line in process.stdout:
            now = time.monotonic() - start
            lines.append(line)
            marks.setdefault("first_line_s", now)
            if match := PROGRESS.search(line):
                done, total = int(match[1]), int(match[2])
                if done == 0:
                    marks.setdefault("writer_ready_s", now)
                if done >= 1:
                    marks.setdefault("first_durable_s", now)
                if done == total:
                    marks.setdefault("all_durable_s", now)
        code = process.wait()
    marks["wall_s"] = time.monotonic() - start
    marks["cpu_s"] = _children_cpu() - cpu_before
    shutil.rmtree(out, ignore_errors=True)
    if code != 0 or len(marks) != len(COLUMNS):
        raise SystemExit(f"the build with {tree} failed ({code}):\n{''.join(lines)[-3000:]}")
    return marks


def worker_profile(tree: Path) -> dict[str, float]:
    code = _WORKER_PROFILE.format(tree=str(tree), config=CONFIG)
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(tree)}  # as in a worker
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tree, env=env, capture_output=True, text=True
    )
    if done.returncode != 0:
        raise SystemExit(f"the worker profile with {tree} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _mean_se(values: list[float]) -> tuple[float, float]:
    se = statistics.stdev(values) / len(values) ** 0.5 if len(values) > 1 else 0.0
    return round(statistics.fmean(values), 3), round(se, 3)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10, help="samples per build")
    parser.add_argument("--repeat", type=int, default=5, help="timed builds per side")
    parser.add_argument("--before", metavar="REV", help="also time the command at this commit")
    parser.add_argument("--worker", action="store_true", help="profile one worker's start-up")
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/startup.json"))
    args = parser.parse_args()

    sides = {"now": REPO}
    worktree = None
    if args.before:
        worktree = Path(tempfile.mkdtemp(prefix="startup-before-")) / "tree"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "--quiet", str(worktree), args.before], check=True)  # fmt: skip
        sides[args.before] = worktree
    runs: dict[str, list[dict[str, float]]] = {name: [] for name in sides}
    profiles: dict[str, dict[str, float]] = {}
    try:
        for tree in sides.values():
            one_build(tree, 2)  # untimed: caches
        for i in range(args.repeat):
            for name, tree in sides.items():
                runs[name].append(one_build(tree, args.samples))
                print(f"run {i + 1}/{args.repeat} {name}: {runs[name][-1]}", file=sys.stderr)
        if args.worker:
            profiles = {name: worker_profile(tree) for name, tree in sides.items()}
    finally:
        if worktree:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(worktree)], check=False)  # fmt: skip
    rows = {name: {c: _mean_se([r[c] for r in rs]) for c in COLUMNS} for name, rs in runs.items()}
    print(f"datagen build {CONFIG} --num-samples {args.samples} --workers 2 --no-preview, "
          f"{args.repeat} runs per side, mean ± standard error, seconds from the command")  # fmt: skip
    print(f"{'side':>10} " + " ".join(f"{c:>17}" for c in COLUMNS))
    for name, row in rows.items():
        print(f"{name:>10} " + " ".join(f"{m:>9.2f} ± {s:<5.2f}" for m, s in row.values()))
    if args.before:
        now, then = rows["now"]["first_durable_s"][0], rows[args.before]["first_durable_s"][0]
        print(f"command -> first durable sample: {then:.2f} s at {args.before}, {now:.2f} s now "
              f"({then / now:.2f}x faster; target <= 3 s)")  # fmt: skip
    for name, steps in profiles.items():
        print(f"one worker's start-up ({name}), seconds: {steps}")
    result = {
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
        "machine": {"cores": os.cpu_count(), "load_average": os.getloadavg()},
        "rows": rows,
        "runs": runs,
        "worker_profile": profiles,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
