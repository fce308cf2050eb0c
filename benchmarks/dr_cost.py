"""What the randomisation costs: frames/s of the default config (every randomiser on) against
``configs/grasp_flat.yaml`` (flat colours, primitives, no surroundings, distractors or sensor
effects: the defaults before issue 16), same resolution, in one run.

    .venv/bin/python benchmarks/dr_cost.py                  # 640x480, 8 scenes per run, 3 pairs
    .venv/bin/python benchmarks/dr_cost.py --samples 3 --repeat 1   # quick
    .venv/bin/python benchmarks/dr_cost.py --before c773fbf          # and the default of a commit

One process produces whole samples (``produce``: build and settle a fresh scene, render,
annotate, apply the sensor effects, PNG-encode), alternating runs of the two configs on the same
sample indices after an untimed warm-up sample each. Reported per config, medians over the
repeats: ms and CPU-seconds per frame, frames/s and the stored bytes per sample; the ratio is
everything ÷ flat in frames/s (target >= 0.8). ``--before REV`` adds a third row, the default
config of commit REV (a git worktree of it, in a child process per run, alternating with the
others): the default's frames/s now ÷ then (issue 26's target: >= 0.8). Results go to
``benchmarks/results/dr_cost.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # as in the workers

REPO = Path(__file__).resolve().parents[1]
CONFIGS = {"flat": "configs/grasp_flat.yaml", "everything": "configs/grasp_tabletop.yaml"}


def _run(config, indices: list[int]) -> dict[str, float]:
    from datagen.families.grasp_tabletop.produce import produce

    wall, cpu, stored = time.perf_counter(), time.process_time(), 0
    for index in indices:
        stored += produce(config, config.seed, index).nbytes
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    frames = len(indices) * config.render.views
    return {
        "ms_per_frame": 1000 * wall / frames,
        "cpu_s_per_frame": cpu / frames,
        "frames_per_s": frames / wall,
        "kib_per_sample": stored / 1024 / len(indices),
    }


_CHILD = """
import dataclasses, json, sys, time
sys.path.insert(0, {tree!r})
import datagen
from datagen.config import load_config
from datagen.families.grasp_tabletop.produce import produce
assert datagen.__file__.startswith({tree!r}), datagen.__file__
config = load_config({tree!r} + "/configs/grasp_tabletop.yaml")
config = config.replace(render=dataclasses.replace(config.render, width={width}, height={height}))
produce(config, config.seed, 10_000)
wall, cpu, stored = time.perf_counter(), time.process_time(), 0
for index in range({samples}):
    stored += produce(config, config.seed, index).nbytes
wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
frames = {samples} * config.render.views
print(json.dumps({{"ms_per_frame": 1000 * wall / frames, "cpu_s_per_frame": cpu / frames,
                  "frames_per_s": frames / wall, "kib_per_sample": stored / 1024 / {samples}}}))
"""


def _run_before(tree: Path, args) -> dict[str, float]:
    """One timed run of the default config of the commit checked out in ``tree`` (warm-up
    untimed), in a child process that imports that tree's datagen."""
    import subprocess

    code = _CHILD.format(tree=str(tree), width=args.width, height=args.height, samples=args.samples)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tree)
    if done.returncode != 0:
        raise SystemExit(f"the run at {args.before} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=8, help="scenes per run")
    parser.add_argument("--repeat", type=int, default=3, help="alternating pairs of runs")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--before", metavar="REV", help="also time the default config of this commit")  # fmt: skip
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/dr_cost.json"))
    args = parser.parse_args()

    import dataclasses

    import sapien

    from datagen.config import load_config
    from datagen.families.grasp_tabletop.produce import produce

    configs = {}
    for name, path in CONFIGS.items():
        config = load_config(REPO / path)
        render = dataclasses.replace(config.render, width=args.width, height=args.height)
        configs[name] = config.replace(render=render)
        produce(configs[name], config.seed, 10_000)  # warm-up, untimed
    indices = list(range(args.samples))
    runs: dict[str, list[dict[str, float]]] = {name: [] for name in configs}
    tree = None
    if args.before:
        import subprocess
        import tempfile

        tree = Path(tempfile.mkdtemp(prefix="dr-cost-before-")) / "tree"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "--quiet", str(tree), args.before], check=True)  # fmt: skip
        runs[f"default@{args.before}"] = []
    try:
        for _ in range(args.repeat):
            for name, config in configs.items():
                runs[name].append(_run(config, indices))
            if tree:
                runs[f"default@{args.before}"].append(_run_before(tree, args))
    finally:
        if tree:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)], check=False)  # fmt: skip
    rows = {
        name: {k: round(statistics.median(r[k] for r in rs), 4) for k in rs[0]}
        for name, rs in runs.items()
    }
    ratio = round(rows["everything"]["frames_per_s"] / rows["flat"]["frames_per_s"], 3)
    print(f"{args.width}x{args.height}, {args.samples} scenes x {args.repeat} runs, medians")
    print(f"{'config':18} {'ms/frame':>9} {'CPU s/frame':>12} {'frames/s':>9} {'KiB/sample':>11}")
    for name, r in rows.items():
        print(
            f"{name:18} {r['ms_per_frame']:9.1f} {r['cpu_s_per_frame']:12.3f} "
            f"{r['frames_per_s']:9.2f} {r['kib_per_sample']:11.0f}"
        )
    print(f"ratio everything / flat, frames/s: {ratio} (target >= 0.8)")
    then = None
    if tree:
        then = round(rows["everything"]["frames_per_s"] / rows[f"default@{args.before}"]["frames_per_s"], 3)  # fmt: skip
        print(f"ratio default now / default at {args.before}, frames/s: {then} (target >= 0.8)")
    result = {
        "command": " ".join(sys.argv),
        "machine": {
            "cores": os.cpu_count(),
            "render_device": sapien.render.get_device_summary().splitlines()[0][:120],
            "load_average": os.getloadavg(),
        },
        "configs": CONFIGS,
        "rows": rows,
        "runs": runs,
        "ratio_frames_per_s": ratio,
        "ratio_now_to_before": then,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
