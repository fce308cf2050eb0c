"""What a path-traced view costs next to a rasterized one (``render.shader: raytraced``), side by
side in one process on the same scenes.

    .venv/bin/python benchmarks/raytracing.py        # 160x120 (5 scenes), 640x480 (3), 16 paths
    .venv/bin/python benchmarks/raytracing.py --sizes 64x48 --scenes 2 --spp 2   # quick

1. **One-time compile**: the process's first path-traced picture (the 32 x 32 picture a worker's
   warm-up renders, one path a pixel, no bounce: SAPIEN compiles its ``rt`` shaders), and then
   the same picture again.
2. **Per picture**: on lavapipe each new path-tracing camera builds its ray-tracing pipeline,
   and a path-traced view's camera is new (``path_tracing.py``): the same 32 x 32 picture with a
   fresh camera, against a second picture of one camera (tracing alone).
3. **Per frame**, for each size, on the workspace camera of default scenes (seed 0, indices
   0..n-1) at that size: ``rasterized``, the pictures of a rasterized view (colour, positions,
   ids, after one untimed capture); ``path-traced colour``, what a path-traced view adds (its
   fresh twin's picture, as a build renders it; the view's labels are the rasterized pictures).

Mesa's shader cache is a fresh temporary folder (a machine's first build), so the figures do not
depend on what earlier runs left in ``~/.cache``. Figures: mean ± standard error over the
repeats. The CPU model, cores, renderer and load average are printed with them, and everything
goes to ``benchmarks/results/raytracing.json``.
"""

from __future__ import annotations

import argparse
import atexit
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from machine import cpu_model  # benchmarks/machine.py

os.environ.setdefault("OMP_NUM_THREADS", "1")  # as in the workers
os.environ["MESA_SHADER_CACHE_DIR"] = tempfile.mkdtemp(prefix="datagen-rt-bench-mesa-")
atexit.register(shutil.rmtree, os.environ["MESA_SHADER_CACHE_DIR"], ignore_errors=True)

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def mean_se(values: list[float]) -> dict[str, float]:
    mean = statistics.fmean(values)
    se = statistics.stdev(values) / len(values) ** 0.5 if len(values) > 1 else float("nan")
    return {"mean": mean, "se": se, "n": len(values)}


def shown(stat: dict[str, float], unit: str = "s") -> str:
    scale = 1000.0 if unit == "ms" else 1.0
    return f"{stat['mean'] * scale:.3g} ± {stat['se'] * scale:.2g} {unit} (n={stat['n']})"


def seconds(action) -> float:
    start = time.perf_counter()
    action()
    return time.perf_counter() - start


def picture(camera) -> None:
    camera.entity.scene.update_render()
    camera.take_picture()
    camera.get_picture("Color")  # waits for the frame


def one_time_and_per_picture(repeats: int) -> dict:
    from datagen.sensing import path_tracing

    scene, camera = path_tracing.probe_scene()
    tiny = path_tracing.PathTracing(samples_per_pixel=1, path_depth=0)
    first = seconds(lambda: path_tracing.raytraced_rgb(camera, tiny))
    again = seconds(lambda: path_tracing.raytraced_rgb(camera, tiny))
    fresh, traced = [], []
    for _ in range(repeats):
        with path_tracing.traced_twin(camera, tiny) as twin:
            fresh.append(seconds(lambda twin=twin: picture(twin)))
            traced.append(seconds(lambda twin=twin: picture(twin)))
    del scene  # held until its camera has rendered
    return {
        "first_picture_s": first,
        "second_picture_s": again,
        "fresh_camera_picture": mean_se(fresh),
        "same_camera_picture": mean_se(traced),
    }


def per_frame(width: int, height: int, scenes: int, tracing) -> dict:
    from datagen.config import BuildConfig
    from datagen.families.grasp_tabletop.world import build_scene
    from datagen.sensing.path_tracing import raytraced_rgb
    from datagen.sensing.render import capture

    base = BuildConfig()
    config = base.replace(render=replace(base.render, width=width, height=height))
    rasterized, traced = [], []
    for index in range(scenes):
        scene = build_scene(config, 0, index)
        scene.scene.update_render()
        camera = scene.cameras["workspace"]
        capture(camera)
        rasterized.append(seconds(lambda camera=camera: capture(camera)))
        traced.append(seconds(lambda camera=camera: raytraced_rgb(camera, tracing)))
        print(
            f"  {width}x{height} scene {index}: rasterized {rasterized[-1] * 1000:.0f} ms, "
            f"path-traced colour {traced[-1]:.2f} s",
            file=sys.stderr,
            flush=True,
        )
    ratio = [t / r for t, r in zip(traced, rasterized, strict=True)]
    return {
        "rasterized_s": mean_se(rasterized),
        "path_traced_colour_s": mean_se(traced),
        "ratio": mean_se(ratio),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="160x120,640x480", help="WxH,WxH,...")
    parser.add_argument("--scenes", default="5,3", help="scenes per size (one value: all)")
    parser.add_argument("--spp", type=int, default=16, help="paths per pixel")
    parser.add_argument("--depth", type=int, default=8, help="bounces after the first hit")
    parser.add_argument("--probe-repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks/results/raytracing.json")
    args = parser.parse_args()
    sizes = [tuple(map(int, size.split("x"))) for size in args.sizes.split(",")]
    counts = [int(n) for n in args.scenes.split(",")]
    counts = counts * len(sizes) if len(counts) == 1 else counts

    import sapien

    from datagen.sensing.path_tracing import PathTracing
    from datagen.sensing.render import keep_renderer_alive

    keep_renderer_alive()
    device = sapien.render.get_device_summary().strip().splitlines()[0].strip()
    machine = {
        "cpu_model": cpu_model(),
        "cores": os.cpu_count(),
        "render_device": device,
        "sapien": sapien.__version__,
        "load_average_at_start": [round(x, 2) for x in os.getloadavg()],
    }
    print(f"machine: {machine['cores']} cores, {machine['cpu_model']}; renderer {device}")
    print(f"load average at start: {machine['load_average_at_start']}")
    probe = one_time_and_per_picture(args.probe_repeats)
    print(
        f"one-time compile: first path-traced picture of the process {probe['first_picture_s']:.2f} s, "
        f"the same picture again {probe['second_picture_s']:.2f} s"
    )
    print(
        f"per picture (32x32, 1 path, no bounce): fresh camera "
        f"{shown(probe['fresh_camera_picture'])}, same camera "
        f"{shown(probe['same_camera_picture'], 'ms')}"
    )
    tracing = PathTracing(samples_per_pixel=args.spp, path_depth=args.depth)
    frames = {}
    print(f"per frame, {args.spp} paths a pixel, path depth {args.depth}:")
    for (width, height), count in zip(sizes, counts, strict=True):
        result = frames[f"{width}x{height}"] = per_frame(width, height, count, tracing)
        print(
            f"  {width}x{height}: rasterized {shown(result['rasterized_s'], 'ms')}; "
            f"path-traced colour {shown(result['path_traced_colour_s'])}; "
            f"ratio {result['ratio']['mean']:.0f} ± {result['ratio']['se']:.2g}"
        )
    machine["load_average_at_end"] = [round(x, 2) for x in os.getloadavg()]
    print(f"load average at end: {machine['load_average_at_end']}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    record = {
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
        "machine": machine,
        "samples_per_pixel": args.spp,
        "path_depth": args.depth,
        "probe": probe,
        "per_frame": frames,
    }
    args.out.write_text(json.dumps(record, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
