"""Where a grasp scene's build and settle time goes, stage by stage, in one process.

    .venv/bin/python benchmarks/build_profile.py                 # 60 scenes after 5 warm-up
    .venv/bin/python benchmarks/build_profile.py --scenes 20     # quick

Builds the scenes of the default grasping config (``configs/grasp_tabletop.yaml``, sample
indices 0..N-1, no rendering) the way a worker does (``datagen.families.grasp_tabletop.world.build_scene``),
with a timer around every call ``construct_scene`` makes: the stages are the functions it calls,
looked up in its module, so the figures are those of the code as it runs. A scene whose targets
land outside the tray is built again (``datagen.worlds.tray_targets``): its stages count twice,
and the rebuilds are counted.

Prints the median milliseconds per scene of each stage, the settle steps and the rebuilds; writes
them with the machine's load average to ``benchmarks/results/build_profile.json`` (git-ignored).
(Until issue 27 it also rebuilt each scene the way datagen did before issue 15, with functions
that no longer exist: docs/performance.md keeps those figures.)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

# as in every datagen worker (datagen/pipeline/executors/base.py): BLAS threads that busy-wait
# would otherwise double the CPU seconds counted for numpy-heavy stages
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import sapien

REPO = Path(__file__).resolve().parents[1]

# (name in datagen.families.grasp_tabletop.world, stage label); sapien.Scene is timed through the module too;
# realise:<type> times the realiser of that scene value type (``realise`` dispatches on it)
STAGES = (
    ("draw_values", "draw the randomised values"),
    ("Scene", "sapien.Scene()"),
    ("_add_part", "table, tray, floor (textured)"),
    ("add_background", "room: walls, ceiling, room lights"),
    ("load_arm", "robot articulation"),
    ("realise:ArmPose", "robot joint pose"),
    ("add_objects", "objects (geometry, collision, render meshes)"),
    ("build_geometry", "  of which, with distractors: geometry (trimesh)"),
    ("add_distractors", "distractors"),
    ("realise:Lighting", "lights"),
    ("pad_lights", "unlit lights (padding)"),
    ("add_camera", "cameras"),
    ("realise:CameraPose", "camera poses"),
    ("settle", "settle (physics steps)"),
)


def _timed(table: dict, key: str, fn):
    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            table[key] += time.perf_counter() - start

    return wrapper


class _SapienWithTimedScene:
    """``sapien`` as ``datagen.families.grasp_tabletop.world`` sees it, with ``Scene()`` timed."""

    def __init__(self, table: dict):
        self._scene = _timed(table, "Scene", sapien.Scene)

    def __getattr__(self, name):
        return self._scene if name == "Scene" else getattr(sapien, name)


def _instrument(table: dict, counters: dict) -> None:
    """Timers around the stages, a counter of physics steps and of scene builds."""
    from datagen.families.grasp_tabletop import world as tabletop
    from datagen.worlds import realise

    tabletop.sapien = _SapienWithTimedScene(table)
    realise.build_geometry = _timed(table, "build_geometry", realise.build_geometry)
    for name, _ in STAGES:
        if name not in {"Scene", "build_geometry"} and not name.startswith("realise:"):
            setattr(tabletop, name, _timed(table, name, getattr(tabletop, name)))
    realise_value = tabletop.realise

    def timed_realise(value, *args, **kwargs):
        return _timed(table, f"realise:{type(value).__name__}", realise_value)(
            value, *args, **kwargs
        )

    tabletop.realise = timed_realise
    construct = tabletop.construct_scene

    def counted_construct(*args, **kwargs):
        counters["builds"] += 1
        return construct(*args, **kwargs)

    tabletop.construct_scene = counted_construct
    step = sapien.Scene.step

    def counted_step(self):
        counters["steps"] += 1
        step(self)

    sapien.Scene.step = counted_step


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=60)
    parser.add_argument("--warmup", type=int, default=5)
    parser.add_argument("--config", default=str(REPO / "configs/grasp_tabletop.yaml"))
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/build_profile.json"))
    args = parser.parse_args()

    from datagen.config import load_config
    from datagen.families.grasp_tabletop import world as tabletop
    from datagen.sensing.render import keep_renderer_alive

    config = load_config(args.config)
    keep_renderer_alive()
    table: dict[str, float] = defaultdict(float)
    counters = {"steps": 0, "builds": 0}
    _instrument(table, counters)
    rows = []
    for i in range(-args.warmup, args.scenes):
        table.clear()
        counters.update(steps=0, builds=0)
        start = time.perf_counter()
        built = tabletop.build_scene(config, config.seed + (1 if i < 0 else 0), abs(i))
        total = time.perf_counter() - start
        del built
        if i >= 0:
            row = {key: table[key] * 1000 for key, _ in STAGES}
            rows.append(row | {"total": total * 1000} | counters)

    median = {k: float(np.median([r[k] for r in rows])) for k in rows[0]}
    print(f"{'median ms per scene':48} {'now':>10}")
    for key, label in [*STAGES, ("total", "build + settle")]:
        print(f"{label:48} {median[key]:10.2f}")
    print(f"{'settle steps (median)':48} {median['steps']:10.0f}")
    rebuilt = sum(r["builds"] - 1 for r in rows)
    print(f"{'scenes built again (targets outside the tray)':48} {rebuilt:10d} of {len(rows)}")
    result = {
        "command": " ".join(sys.argv),
        "scenes": args.scenes,
        "load_average": os.getloadavg(),
        "cores": os.cpu_count(),
        "median_ms": median,
        "rebuilt": rebuilt,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
