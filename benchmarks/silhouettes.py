"""The robot's amodal silhouettes (``visible_fraction`` of the arm and the gripper): time per
view now and at an earlier commit, on the same projected triangles, in one run.

    .venv/bin/python benchmarks/silhouettes.py --before 0c58188
    .venv/bin/python benchmarks/silhouettes.py --samples 2 --repeat 3   # quick

Renders ``--samples`` default grasp samples (640x480) and records every outline set the robot
labels count (``silhouette_pixels`` without margin: the Panda's 126,598 triangles for the arm,
8,950 for the gripper); then each side (this tree, and ``--before REV`` from a git worktree, in a
child process) counts them ``--repeat`` times. Reported: per outline set, the triangles, the
counts (which must agree between the sides) and the best time of each side; the sum per view.
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

_TIMER = """
import json, pickle, sys, time
sys.path.insert(0, {tree!r})
from datagen.sensing.silhouette import silhouette_pixels
results = []
for outlines, width, height in pickle.load(open({recorded!r}, "rb")):
    best = float("inf")
    for _ in range({repeat}):
        start = time.perf_counter()
        counts = silhouette_pixels(outlines, width, height, margin=0.0)
        best = min(best, time.perf_counter() - start)
    results.append({{"triangles": len(outlines), "counts": list(counts), "ms": 1000 * best}})
print(json.dumps(results))
"""


def record(samples: int, path: Path) -> None:
    from datagen.config import load_config
    from datagen.pipeline.production import Task, produce_with_policy
    from datagen.sensing import robot_labels

    recorded = []
    count = robot_labels.silhouette_pixels

    def recording(outlines, width, height, **options):
        recorded.append((outlines.copy(), width, height))  # robot labels count without margin
        return count(outlines, width, height, **options)

    robot_labels.silhouette_pixels = recording
    config = load_config(REPO / "configs/grasp_tabletop.yaml")
    for index in range(samples):
        produce_with_policy(config, Task(index))
    path.write_bytes(pickle.dumps(recorded))


def timed(tree: Path, recorded: Path, repeat: int) -> list[dict]:
    code = _TIMER.format(tree=str(tree), recorded=str(recorded), repeat=repeat)
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(tree)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"timing with {tree} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=4)
    parser.add_argument("--repeat", type=int, default=7, help="timings per outline set (best)")
    parser.add_argument("--before", metavar="REV", help="also time this commit's counting")
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/silhouettes.json"))
    args = parser.parse_args()

    scratch = Path(tempfile.mkdtemp(prefix="silhouettes-"))
    recorded = scratch / "outlines.pkl"
    record(args.samples, recorded)
    sides = {"now": timed(REPO, recorded, args.repeat)}
    if args.before:
        tree = scratch / "tree"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "--quiet", str(tree), args.before], check=True)  # fmt: skip
        try:
            sides[args.before] = timed(tree, recorded, args.repeat)
        finally:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)], check=False)  # fmt: skip
    names = list(sides)
    print(f"{'triangles':>10} {'counts (whole, in image)':>26} " + " ".join(f"{n + ' ms':>14}" for n in names))  # fmt: skip
    for rows in zip(*sides.values(), strict=True):
        if any(r["counts"] != rows[0]["counts"] for r in rows):
            raise SystemExit(f"the sides count differently: {rows}")
        print(f"{rows[0]['triangles']:>10} {rows[0]['counts']!s:>26} " + " ".join(f"{r['ms']:>14.1f}" for r in rows))  # fmt: skip
    views = args.samples  # one workspace view per sample
    totals = {n: sum(r["ms"] for r in rows) / views for n, rows in sides.items()}
    print("per view, arm + gripper: " + ", ".join(f"{n} {t:.1f} ms" for n, t in totals.items()))
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    result = {"command": " ".join(sys.argv), "sides": sides, "ms_per_view": totals}
    Path(args.out).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
