"""Several views per settled scene: frames/s with ``render.views`` 1 against 4, in one run.

    .venv/bin/python benchmarks/views.py                 # 640x480, 6 scenes per run, 3 pairs
    .venv/bin/python benchmarks/views.py --samples 3 --repeat 1   # quick

One process produces whole samples (``produce``: build and settle a fresh scene, render,
annotate and PNG-encode every view) of the default grasp config, alternating runs of
``render.views: 1`` and ``4`` on the same sample indices. An untimed sample first warms each
config (shader compile). A frame is one annotated view: a 4-view sample is 4 frames.
Reported per config, medians over the repeats: milliseconds and CPU-seconds (this process,
renderer threads included) per sample and per frame, and frames/s; the ratio row is 4 views ÷
1 view in frames/s. Results and the machine's load go to ``benchmarks/results/views.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _run(config, seed: int, indices: list[int]) -> dict[str, float]:
    from datagen.families.grasp_tabletop.produce import produce

    wall, cpu = time.perf_counter(), time.process_time()
    for index in indices:
        produce(config, seed, index)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    frames = len(indices) * config.render.views
    return {
        "ms_per_sample": 1000 * wall / len(indices),
        "ms_per_frame": 1000 * wall / frames,
        "cpu_s_per_frame": cpu / frames,
        "frames_per_s": frames / wall,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=6, help="scenes per run")
    parser.add_argument("--repeat", type=int, default=3, help="alternating pairs of runs")
    parser.add_argument("--views", type=int, default=4, help="views of the multi-view config")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/views.json"))
    args = parser.parse_args()

    import dataclasses

    import sapien

    from datagen.config import load_config
    from datagen.families.grasp_tabletop.produce import produce

    base = load_config(REPO / "configs/grasp_tabletop.yaml")
    configs = {
        views: base.replace(
            render=dataclasses.replace(
                base.render, width=args.width, height=args.height, views=views
            )
        )
        for views in (1, args.views)
    }
    for config in configs.values():
        produce(config, base.seed, 10_000)  # warm-up, untimed
    indices = list(range(args.samples))
    runs: dict[int, list[dict[str, float]]] = {views: [] for views in configs}
    for _ in range(args.repeat):
        for views, config in configs.items():
            runs[views].append(_run(config, base.seed, indices))
    rows = {
        f"views={views}": {k: round(statistics.median(r[k] for r in rs), 4) for k in rs[0]}
        for views, rs in runs.items()
    }
    one, many = rows["views=1"], rows[f"views={args.views}"]
    ratio = round(many["frames_per_s"] / one["frames_per_s"], 3)
    print(f"{args.width}x{args.height}, {args.samples} scenes x {args.repeat} runs, medians")
    print(f"{'config':10} {'ms/sample':>10} {'ms/frame':>9} {'CPU s/frame':>12} {'frames/s':>9}")
    for name, r in rows.items():
        print(
            f"{name:10} {r['ms_per_sample']:10.1f} {r['ms_per_frame']:9.1f} "
            f"{r['cpu_s_per_frame']:12.3f} {r['frames_per_s']:9.2f}"
        )
    print(f"ratio {args.views} views / 1 view, frames/s: {ratio}")
    result = {
        "command": " ".join(sys.argv),
        "machine": {
            "cores": os.cpu_count(),
            "render_device": sapien.render.get_device_summary().splitlines()[0][:120],
            "load_average": os.getloadavg(),
        },
        "rows": rows,
        "runs": {f"views={v}": rs for v, rs in runs.items()},
        "ratio_frames_per_s": ratio,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
