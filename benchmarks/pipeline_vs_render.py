"""Plain SAPIEN render loop vs the whole datagen pipeline, side by side in one run.

    .venv/bin/python benchmarks/pipeline_vs_render.py [--num-samples 200] [--workers N]

(a) plain: W spawned processes, each calling ``render_annotated(config, seed, i)`` for the
    indices ``i % W == w`` (build scene, render, annotate; no encoding, MQTT or writer).
(b) pipeline: ``run_build(config, tmp_dir, W)`` (broker, writer, W workers, manifest), into a
    temporary directory that is deleted afterwards.

Both render the same scenes (config, seed, indices) with the same annotations.

Two figures for each:
- end-to-end wall: from just before the first process is launched until every process has
  exited (plain) or ``run_build`` has returned (pipeline): start-up, shader warm-up, the
  broker/writer start and the manifest are all inside, as a user would see it.
- steady state: (N - W) frames over the time from the W-th to the N-th completed frame, which
  leaves out each process's start-up and first (shader warm-up) frame on both sides. A frame is
  "completed" when ``render_annotated`` returns (plain) or when the writer has acknowledged the
  sample as durable (pipeline).

Before the timed runs, one untimed process renders one frame so that Mesa's on-disk shader
cache is equally warm for (a) and (b).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import platform
import queue
import resource
import shlex
import statistics
import sys
import tempfile
import time
import traceback
from dataclasses import replace
from pathlib import Path
from typing import Any

from machine import cpu_model  # benchmarks/machine.py
from tqdm import tqdm

from datagen.config import BuildConfig, config_from_dict, load_config
from datagen.errors import ConfigError
from datagen.pipeline.executors.base import WORKER_ENV_DEFAULTS, default_env

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "pipeline_vs_render.json"
DEFAULT_CONFIG = ROOT / "configs" / "grasp_tabletop.yaml"


# ---------------------------------------------------------------------------------- (a) plain


def _plain_worker(worker: int, workers: int, config_dict: dict[str, Any], events) -> None:
    """Spawned process: renders and annotates its share of the indices; reports each frame."""
    try:
        from datagen.families.grasp_tabletop.produce import render_annotated

        config = config_from_dict(config_dict)
        for index in range(worker, config.num_samples, workers):
            render_annotated(config, config.seed, index)
            events.put(("frame", worker, time.monotonic()))
        events.put(("done", worker, None))
    except Exception:
        events.put(("error", worker, traceback.format_exc()))
        raise SystemExit(1) from None


def run_plain(config: BuildConfig, workers: int) -> dict[str, Any]:
    context = mp.get_context("spawn")
    events = context.Queue()
    processes = [
        context.Process(
            target=_plain_worker,
            args=(w, workers, config.to_dict(), events),
            name=f"plain-render-{w}",
            daemon=True,
        )
        for w in range(workers)
    ]
    done_times: list[float] = []
    finished: set[int] = set()
    bar = tqdm(total=config.num_samples, desc="(a) plain   ", unit="frame", file=sys.stderr)
    cpu = _cpu_seconds()
    start = time.monotonic()
    try:
        with default_env(WORKER_ENV_DEFAULTS):  # the same thread settings as pipeline workers
            for process in processes:
                process.start()
        while len(finished) < workers:
            try:
                kind, worker, payload = events.get(timeout=1.0)
            except queue.Empty:
                kind, worker, payload = "idle", -1, None
            if kind == "idle":
                for w, process in enumerate(processes):
                    if w not in finished and not process.is_alive():
                        raise RuntimeError(f"{process.name} died (exit code {process.exitcode})")
            elif kind == "frame":
                done_times.append(payload)
                bar.update(1)
            elif kind == "done":
                finished.add(worker)
            else:
                raise RuntimeError(f"plain render worker {worker} failed:\n{payload}")
        for process in processes:
            process.join()
        wall = time.monotonic() - start
        cpu = _cpu_seconds() - cpu
    finally:
        bar.close()
        for process in processes:
            if process.is_alive():
                process.kill()
                process.join()
    return _figures(config.num_samples, workers, wall, cpu, start, sorted(done_times))


# ------------------------------------------------------------------------------- (b) pipeline


def run_pipeline(config: BuildConfig, workers: int) -> dict[str, Any]:
    from datagen.pipeline.run import run_build

    # completion k (1-based) -> the first moment at least k samples were durable
    done_times: list[float] = []
    bar = tqdm(total=config.num_samples, desc="(b) pipeline", unit="frame", file=sys.stderr)

    def on_progress(done: int, total: int) -> None:
        now = time.monotonic()
        while len(done_times) < done:
            done_times.append(now)
        bar.update(done - bar.n)

    with tempfile.TemporaryDirectory(prefix="datagen-bench-") as tmp:
        try:
            cpu = _cpu_seconds()
            start = time.monotonic()
            result = run_build(config, Path(tmp) / "dataset", workers, on_progress=on_progress)
            wall = time.monotonic() - start
            cpu = _cpu_seconds() - cpu
        finally:
            bar.close()
    if result.samples != config.num_samples:
        raise RuntimeError(f"the build wrote {result.samples} samples, not {config.num_samples}")
    return _figures(config.num_samples, workers, wall, cpu, start, done_times)


# ------------------------------------------------------------------------------------ figures


def _cpu_seconds() -> float:
    """CPU time (user + system) of this process and of its children that have exited."""
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _figures(
    frames: int, workers: int, wall: float, cpu: float, start: float, done_times: list[float]
) -> dict[str, Any]:
    if len(done_times) != frames:
        raise RuntimeError(f"saw {len(done_times)} completed frames, expected {frames}")
    steady_frames = frames - workers
    steady_s = done_times[-1] - done_times[workers - 1] if steady_frames > 0 else float("nan")
    return {
        "frames": frames,
        "wall_s": round(wall, 3),
        "wall_fps": round(frames / wall, 3),
        # every process of the run: workers, and for the pipeline also broker, writer, coordinator
        "cpu_s": round(cpu, 2),
        "cpu_s_per_frame": round(cpu / frames, 4),
        "first_completion_s": round(done_times[0] - start, 3),
        "last_completion_s": round(done_times[-1] - start, 3),
        "steady_frames": steady_frames,
        "steady_s": round(steady_s, 3),
        "steady_fps": round(steady_frames / steady_s, 3) if steady_frames > 0 else None,
    }


def _ratios(plain: dict[str, Any], pipeline: dict[str, Any]) -> dict[str, float | None]:
    steady = None
    if plain["steady_fps"] and pipeline["steady_fps"]:
        steady = round(pipeline["steady_fps"] / plain["steady_fps"], 3)
    return {"wall": round(pipeline["wall_fps"] / plain["wall_fps"], 3), "steady": steady}


# ------------------------------------------------------------------------------------ machine


def _warm_up(config_dict: dict[str, Any], answer) -> None:
    """Spawned process: one untimed frame (fills Mesa's shader cache); sends the device."""
    import sapien

    from datagen.families.grasp_tabletop.produce import render_annotated

    config = config_from_dict(config_dict)
    render_annotated(config, config.seed, 0)
    answer.put(sapien.render.get_device_summary().strip())


def warm_up_and_probe(config: BuildConfig) -> str:
    context = mp.get_context("spawn")
    answer = context.Queue()
    process = context.Process(target=_warm_up, args=(config.to_dict(), answer), daemon=True)
    process.start()
    try:
        device = answer.get(timeout=300)
    finally:
        process.join(timeout=60)
    return device


def machine(device_summary: str, load_average: tuple[float, ...]) -> dict[str, Any]:
    return {
        "cores": os.cpu_count(),
        "cpu_model": cpu_model(),
        "render_device": device_summary,
        "platform": platform.platform(),
        "python": platform.python_version(),
        "LP_NUM_THREADS": os.environ.get("LP_NUM_THREADS"),
        "load_average_at_start": [round(x, 2) for x in load_average],
    }


# ------------------------------------------------------------------------------------- report


def _table(plain: dict[str, Any], pipeline: dict[str, Any], ratios: dict[str, Any]) -> str:
    head = (
        f"{'':24}{'frames':>7}{'wall s':>9}{'wall f/s':>10}{'steady s':>10}{'steady f/s':>12}"
        f"{'CPU s/frame':>13}"
    )
    rows = [head, "-" * len(head)]
    for name, r in (("(a) plain render loop", plain), ("(b) whole pipeline", pipeline)):
        rows.append(
            f"{name:24}{r['frames']:>7}{r['wall_s']:>9.2f}{r['wall_fps']:>10.3f}"
            f"{r['steady_s']:>10.2f}{r['steady_fps'] or float('nan'):>12.3f}"
            f"{r['cpu_s_per_frame']:>13.3f}"
        )
    steady = ratios["steady"] if ratios["steady"] is not None else float("nan")
    rows.append(
        f"{'ratio (b) / (a) f/s':24}{'':7}{'':9}{ratios['wall']:>10.3f}{'':10}{steady:>12.3f}"
    )
    return "\n".join(rows)


def _median_run(runs: list[dict[str, Any]], key: str) -> dict[str, Any]:
    fields = ("wall_s", "wall_fps", "steady_s", "steady_fps", "cpu_s", "cpu_s_per_frame")
    out = dict(runs[0][key])
    for f in fields:
        values = [r[key][f] for r in runs if r[key][f] is not None]
        out[f] = round(statistics.median(values), 3) if values else None
    return out


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--config", default=str(DEFAULT_CONFIG), help="build config YAML")
    p.add_argument("--num-samples", type=int, default=200, help="frames per run (default 200)")
    p.add_argument(
        "--workers",
        type=int,
        default=os.cpu_count() or 1,
        help="render processes in (a) and pipeline workers in (b) (default: number of cores)",
    )
    p.add_argument("--width", type=int, help="override the config's render width")
    p.add_argument("--height", type=int, help="override the config's render height")
    p.add_argument(
        "--repeat", type=int, default=1, help="alternating (a), (b) pairs; medians are reported"
    )
    p.add_argument("--out", default=str(RESULTS), help=f"JSON results (default {RESULTS})")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.workers < 1 or args.repeat < 1 or args.num_samples < 1:
        _parser().error("--workers, --repeat and --num-samples must be >= 1")
    try:
        config = load_config(args.config).replace(num_samples=args.num_samples)
        render = config.render
        if args.width or args.height:
            render = replace(
                render, width=args.width or render.width, height=args.height or render.height
            )
            config = config.replace(render=render)
        config = config_from_dict(config.to_dict(), source="benchmark config")  # checks ranges
    except ConfigError as exc:
        _parser().error(f"config error: {exc}")

    command = shlex.join([sys.executable, *sys.argv])
    load_average = os.getloadavg()  # before our own warm-up adds to it
    print(f"command: {command}", file=sys.stderr)
    print("warm-up: one untimed frame in a separate process (Mesa shader cache)", file=sys.stderr)
    device = warm_up_and_probe(config)
    info = machine(device, load_average)

    runs = []
    for r in range(args.repeat):
        plain = run_plain(config, args.workers)
        pipeline = run_pipeline(config, args.workers)
        runs.append(
            {"repeat": r, "plain": plain, "pipeline": pipeline, "ratio": _ratios(plain, pipeline)}
        )

    lines = [
        f"command: {command}",
        f"machine: {info['cores']} cores, {info['cpu_model']}; "
        f"LP_NUM_THREADS={info['LP_NUM_THREADS'] or 'unset'}; "
        f"load average at start {info['load_average_at_start']}",
        f"render device: {device.splitlines()[0] if device else 'unknown'}",
        f"scenes: {config.scene}, seed {config.seed}, indices 0..{config.num_samples - 1}, "
        f"{render.width}x{render.height}, wrist camera {'on' if render.wrist_camera else 'off'}; "
        f"{args.workers} processes in each of (a) and (b)",
        "",
    ]
    for run in runs:
        if args.repeat > 1:
            lines.append(f"run {run['repeat'] + 1} of {args.repeat}")
        lines += [_table(run["plain"], run["pipeline"], run["ratio"]), ""]
    summary = None
    if args.repeat > 1:
        plain, pipeline = _median_run(runs, "plain"), _median_run(runs, "pipeline")
        # the ratio of each (a), (b) pair, run back to back, then the median of those ratios
        ratio = {
            k: round(statistics.median(r["ratio"][k] for r in runs), 3)
            if all(r["ratio"][k] is not None for r in runs)
            else None
            for k in ("wall", "steady")
        }
        summary = {"plain": plain, "pipeline": pipeline, "ratio": ratio}
        lines += [
            f"median of {args.repeat} runs (ratio row: median of the per-run ratios)",
            _table(plain, pipeline, ratio),
            "",
        ]
    lines.append(
        "wall = launch to last process exit / run_build return; steady = (N - W) frames "
        "between the W-th and N-th completed frame (pipeline: durable)."
    )
    print("\n".join(lines))

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    doc = {
        "benchmark": "pipeline_vs_render",
        "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "command": command,
        "machine": info,
        "workers": args.workers,
        "config": config.to_dict(),
        "definitions": {
            "wall": "from just before launching the first process to every process exited "
            "(plain) / run_build returned (pipeline)",
            "steady": "(N - W) frames over the time from the W-th to the N-th completed frame; "
            "completed = render_annotated returned (plain) / sample acknowledged as durable "
            "(pipeline)",
        },
        "runs": runs,
        "median": summary,
    }
    out.write_text(json.dumps(doc, indent=2) + "\n")
    print(f"results: {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
