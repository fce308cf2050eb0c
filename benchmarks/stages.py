"""Where one frame's time and CPU go, stage by stage, before and after issue 15, in one run.

    .venv/bin/python benchmarks/stages.py [--frames 20] [--warm-up 2]

One process renders the default grasp config (640x480) frame by frame, alternating two
variants on the same indices:
- before: the old read-back conversion (``picture_conversion.rgb_reference`` /
  ``depth_reference``: float temporaries) and the four PNGs of a view encoded one after another;
- after: what the library does now (one-pass conversions, the PNG thread pool).
Per frame and stage, wall milliseconds and process CPU milliseconds (``time.process_time``: all
threads of the process, lavapipe's rasteriser threads included) from the stage clock
(``datagen/sensing/stage_clock.py``), medians over the frames after the warm-up:
build + settle (``build_scene``), render (``take_picture`` and the first ``get_picture``, which
waits for the frame), read_back (the other pictures), convert, annotate (labels, records,
metadata), encode (PNG + JSON). Non-render CPU = the frame's CPU minus the render stage's.
Publishing is not in this process: ``benchmarks/pipeline_vs_render.py`` and ``scaling.py``
measure it through a real broker.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import sys
import time
from pathlib import Path

# as in every datagen worker (datagen/pipeline/executors/base.py): BLAS threads that busy-wait
# would otherwise double the CPU seconds counted for numpy-heavy stages
os.environ.setdefault("OMP_NUM_THREADS", "1")
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "stages.json"
DEFAULT_CONFIG = ROOT / "configs" / "grasp_tabletop.yaml"
STAGES = ("build", "settle", "render", "read_back", "convert", "annotate", "encode")


def _frame(config, index: int, before: bool) -> tuple[dict[str, float], dict[str, float]]:
    """One frame; ``({stage: wall s}, {stage: CPU s})`` with ``frame`` = the whole frame."""
    from datagen.families.grasp_tabletop.produce import annotate_scene, to_sample
    from datagen.families.grasp_tabletop.world import build_scene
    from datagen.sensing import encode, picture_conversion, stage_clock

    saved = (picture_conversion.rgb_from_colour, picture_conversion.depth_from_position)
    threads = encode._ENCODE_THREADS
    if before:
        picture_conversion.rgb_from_colour = lambda rgba, *_: picture_conversion.rgb_reference(rgba)
        picture_conversion.depth_from_position = lambda p, *_: picture_conversion.depth_reference(p)
        encode._ENCODE_THREADS = 1
    try:
        stage_clock.take(), stage_clock.take_cpu()
        wall0, cpu0 = time.perf_counter(), time.process_time()
        with stage_clock.timed("build+settle"):
            scene = build_scene(config, config.seed, index)
        with stage_clock.timed("annotate"):
            annotated = annotate_scene(scene, config, config.seed, index)
        to_sample(annotated, config.output.png_level)
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    finally:
        picture_conversion.rgb_from_colour, picture_conversion.depth_from_position = saved
        encode._ENCODE_THREADS = threads
    walls, cpus = stage_clock.take(), stage_clock.take_cpu()
    out = []
    for clock, total in ((walls, wall), (cpus, cpu)):
        s = {k.removesuffix("_s"): v for k, v in clock.items()}
        inner = sum(s.get(k, 0.0) for k in ("render", "read_back", "convert"))
        s["annotate"] = s.get("annotate", 0.0) - inner  # labels and records only
        nested = sum(s.get(k, 0.0) for k in ("build", "settle"))
        if nested:  # the scene builder times its own stages: the rest of the build is "build"
            s["build"] = s.pop("build+settle") - s.get("settle", 0.0)
        else:
            s["build"] = s.pop("build+settle")
        s["frame"] = total
        s["non_render"] = total - s.get("render", 0.0)
        out.append(s)
    return out[0], out[1]


def _medians(rows: list[dict[str, float]]) -> dict[str, float]:
    keys = sorted({k for r in rows for k in r})
    return {k: round(1000 * statistics.median(r.get(k, 0.0) for r in rows), 2) for k in keys}


def _table(result: dict[str, Any]) -> str:
    b, a = result["before"], result["after"]
    head = f"{'stage':12}{'before ms':>11}{'CPU ms':>9}{'after ms':>11}{'CPU ms':>9}{'after/before CPU':>18}"
    rows = [head, "-" * len(head)]
    for stage in (*STAGES, "frame", "non_render"):
        if stage not in a["wall_ms"] and stage not in b["wall_ms"]:
            continue
        bw, bc = b["wall_ms"].get(stage, 0.0), b["cpu_ms"].get(stage, 0.0)
        aw, ac = a["wall_ms"].get(stage, 0.0), a["cpu_ms"].get(stage, 0.0)
        ratio = f"{ac / bc:.2f}" if bc > 0 else "-"
        rows.append(f"{stage:12}{bw:>11.1f}{bc:>9.1f}{aw:>11.1f}{ac:>9.1f}{ratio:>18}")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", default=str(DEFAULT_CONFIG), help="build config YAML")
    parser.add_argument("--frames", type=int, default=20, help="timed frames per variant")
    parser.add_argument("--warm-up", type=int, default=2, help="untimed frames per variant first")
    parser.add_argument("--out", default=str(RESULTS), help=f"JSON results (default {RESULTS})")
    args = parser.parse_args(argv)
    if args.frames < 1 or args.warm_up < 0:
        parser.error("--frames must be >= 1 and --warm-up >= 0")

    import sapien

    from datagen.config import load_config
    from datagen.errors import ConfigError
    from datagen.sensing.render import keep_renderer_alive

    try:
        config = load_config(args.config)
    except ConfigError as exc:
        parser.error(f"config error: {exc}")
    command = shlex.join([sys.executable, *sys.argv])
    load_average = os.getloadavg()
    keep_renderer_alive()
    rows: dict[str, dict[str, list]] = {v: {"wall": [], "cpu": []} for v in ("before", "after")}
    for i in range(args.warm_up + args.frames):
        for variant in ("before", "after") if i % 2 == 0 else ("after", "before"):
            wall, cpu = _frame(config, i, variant == "before")
            if i >= args.warm_up:
                rows[variant]["wall"].append(wall)
                rows[variant]["cpu"].append(cpu)
        print(f"frame {i + 1}/{args.warm_up + args.frames}", file=sys.stderr, end="\r")
    result = {
        v: {"wall_ms": _medians(rows[v]["wall"]), "cpu_ms": _medians(rows[v]["cpu"])} for v in rows
    }
    device = sapien.render.get_device_summary().strip().splitlines()
    lines = [
        f"command: {command}",
        f"machine: {os.cpu_count()} cores; load average at start {[round(x, 2) for x in load_average]}; "
        f"render device: {device[0] if device else 'unknown'}",
        f"scenes: {config.scene}, seed {config.seed}, {config.render.width}x{config.render.height}, "
        f"PNG level {config.output.png_level}; medians of {args.frames} frames per variant "
        f"after {args.warm_up} warm-up, variants alternating on the same indices",
        "",
        _table(result),
        "",
        "render = take_picture + the first get_picture (waits for the frame); non_render = "
        "frame - render; CPU = process CPU of all threads; publish: see pipeline_vs_render.py",
    ]
    print("\n".join(lines))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    doc = {
        "benchmark": "stages",
        "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "command": command,
        "load_average_at_start": load_average,
        "render_device": device,
        "config": config.to_dict(),
        "frames": args.frames,
        "result": result,
        "frames_raw": rows,
    }
    out.write_text(json.dumps(doc, indent=2) + "\n")
    print(f"results: {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
