"""One picture of the saved benchmark results: ``docs/images/benchmarks.png``.

    .venv/bin/python benchmarks/summary.py      # after the benchmarks have written their JSON

Panels (each from ``benchmarks/results/<name>.json``, skipped if missing): pipeline against the
plain render loop; datagen against ManiSkill's RecordEpisode; scaling with local and Ray
workers; where a frame's time goes; worker memory over a long build.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from matplotlib.figure import Figure

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks/results"


def _load(name: str) -> dict | None:
    path = RESULTS / f"{name}.json"
    return json.loads(path.read_text()) if path.is_file() else None


def _bars(ax, labels, values, title, unit="frames/s"):
    bars = ax.bar(
        range(len(values)),
        values,
        color=["#4878a8", "#e07b39", "#6aa84f", "#a64d79"][: len(values)],
    )
    ax.set_xticks(range(len(values)), labels, fontsize=8)
    ax.bar_label(bars, fmt="%.2f", fontsize=8)
    ax.set_ylabel(unit)
    ax.set_title(title, fontsize=10)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="PNG to write (default: docs/images/benchmarks.png)")
    args = parser.parse_args(argv)
    fig = Figure(figsize=(15, 8.5))
    axes = fig.subplots(2, 3).ravel()
    used = 0
    if p := _load("pipeline_vs_render"):
        r = p["runs"][0]
        _bars(axes[used], ["plain render\nloop", "whole\npipeline"], [r["plain"]["steady_fps"], r["pipeline"]["steady_fps"]],
              f"(a) pipeline ÷ render loop = {r['ratio']['steady']:.2f} (steady, 640x480)")  # fmt: skip
        used += 1
    if m := _load("vs_maniskill"):
        rows = m["rows"]
        _bars(axes[used], [k.replace(", ", "\n") for k in rows], [r["frames_per_s"] for r in rows.values()],
              "(b) datagen vs ManiSkill RecordEpisode (wall, 640x480)")  # fmt: skip
        used += 1
    if s := _load("scaling"):
        ax = axes[used]
        for executor, colour in (("local", "#4878a8"), ("ray", "#e07b39")):
            points = sorted((int(k.split(", ")[1].split()[0]), v["steady_fps"]) for k, v in s["rows"].items() if k.startswith(executor))  # fmt: skip
            ax.plot(*zip(*points, strict=True), marker="o", label=executor, color=colour)
        ax.set_xlabel("workers")
        ax.set_ylabel("steady frames/s")
        ax.set_title("(c) scaling: local processes vs Ray actors", fontsize=10)
        ax.legend()
        used += 1
        ax = axes[used]
        names = list(s["stages"])
        bottom = [0.0] * len(names)
        for stage, colour in (("render", "#4878a8"), ("encode", "#e07b39"), ("publish", "#6aa84f")):
            values = [s["stages"][n]["ms_per_frame"][stage] for n in names]
            ax.bar(range(len(names)), values, bottom=bottom, label=stage, color=colour)
            bottom = [b + v for b, v in zip(bottom, values, strict=True)]
        ax.set_xticks(range(len(names)), [n.replace("local, ", "") for n in names], fontsize=8)
        ax.set_ylabel("ms per frame, per worker")
        share = s["stages"][names[-1]]["share"]
        ax.set_title(f"(d) encode {share['encode']:.1%}, transfer {share['publish']:.1%} of a frame", fontsize=10)  # fmt: skip
        ax.legend(fontsize=8)
        used += 1
    if mem := _load("memory"):
        ax = axes[used]
        for name, row in mem["rows"].items():
            points = [(done, sum(rss) / len(rss)) for _, done, rss in row["timeline"] if rss]
            ax.plot(*zip(*points, strict=True), label=name, lw=1)
        ax.set_xlabel("frames durable")
        ax.set_ylabel("mean worker RSS (MiB)")
        ax.set_title("(e) worker memory over a long build", fontsize=10)
        ax.legend(fontsize=8)
        used += 1
    for ax in axes[used:]:
        ax.axis("off")
    fig.tight_layout()
    out = Path(args.out) if args.out else REPO / "docs/images/benchmarks.png"
    fig.savefig(out, dpi=70)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
