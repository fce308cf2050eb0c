"""Where a grasp scene's build and settle time goes, stage by stage, in one process.

    .venv/bin/python benchmarks/build_profile.py                 # 60 scenes after 5 warm-up
    .venv/bin/python benchmarks/build_profile.py --scenes 20     # quick

Builds the scenes of the default grasping config (``configs/grasp_tabletop.yaml``, sample
indices 0..N-1, no rendering) the way a worker does (``datagen.worlds.tabletop.build_scene``),
with a timer around every call ``construct_scene`` makes: the stages are the functions it calls,
looked up in its module, so the figures are those of the code as it runs. Two sides, scene by
scene in turn so both see the same machine load:

- **before issue 15**: the Panda's URDF parsed again for every scene, and every scene settled
  for the full ``physics.settle_time`` with the robot awake (what datagen did before);
- **now**: the Panda built from the process's parsed builder (``datagen.worlds.robots``), and
  settling ends once the objects rest, the robot asleep meanwhile (``datagen.worlds.settle``).

Prints the median milliseconds per scene of each stage and side, the settle steps and the ratio;
writes them with the machine's load average to ``benchmarks/results/build_profile.json``
(git-ignored).
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

# (name in datagen.worlds.tabletop, stage label); sapien.Scene is timed through the module too
STAGES = (
    ("sample_scene", "sample the randomised values"),
    ("Scene", "sapien.Scene()"),
    ("add_ground", "ground plane"),
    ("box_entity", "table and tray (static boxes)"),
    ("load_panda", "Panda articulation"),
    ("apply_robot", "robot joint pose"),
    ("add_objects", "objects (geometry, collision, render meshes)"),
    ("build_geometry", "  of which: geometry (trimesh)"),
    ("apply_lighting", "lights"),
    ("add_camera", "cameras"),
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
    """``sapien`` as ``datagen.worlds.tabletop`` sees it, with ``Scene()`` timed."""

    def __init__(self, table: dict):
        self._scene = _timed(table, "Scene", sapien.Scene)

    def __getattr__(self, name):
        return self._scene if name == "Scene" else getattr(sapien, name)


def _parse_panda_every_time(scene: sapien.Scene) -> sapien.physx.PhysxArticulation:
    from datagen.worlds.tabletop import panda_urdf

    loader = scene.create_urdf_loader()
    loader.fix_root_link = True
    return loader.load(str(panda_urdf()))


def _settle_full_time(scene, bodies, radii, robot, max_steps, settle_velocity) -> int:
    for _ in range(max_steps):
        scene.step()
    return max_steps


def _instrument(table: dict, side: dict) -> None:
    """Timers around the stages; ``side`` holds the Panda loader and the settle in use."""
    from datagen.worlds import realise as objects_module
    from datagen.worlds import tabletop

    sapien.Scene.add_ground = _timed(table, "add_ground", sapien.Scene.add_ground)
    sapien.Scene.add_camera = _timed(table, "add_camera", sapien.Scene.add_camera)
    tabletop.sapien = _SapienWithTimedScene(table)
    objects_module.build_geometry = _timed(table, "build_geometry", objects_module.build_geometry)
    tabletop.load_panda = _timed(table, "load_panda", lambda scene: side["load_panda"](scene))
    tabletop.settle = _timed(table, "settle", lambda *a, **k: side["settle"](*a, **k))
    for name, _ in STAGES:
        if name not in {"Scene", "add_ground", "add_camera", "build_geometry", "load_panda"}:
            setattr(tabletop, name, _timed(table, name, getattr(tabletop, name)))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=60)
    parser.add_argument("--warmup", type=int, default=5)
    parser.add_argument("--config", default=str(REPO / "configs/grasp_tabletop.yaml"))
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/build_profile.json"))
    args = parser.parse_args()

    from datagen.config import load_config
    from datagen.engines.sim.render import keep_renderer_alive
    from datagen.worlds import tabletop

    config = load_config(args.config)
    keep_renderer_alive()
    sides = {
        "before issue 15": {"load_panda": _parse_panda_every_time, "settle": _settle_full_time},
        "now": {"load_panda": tabletop.load_panda, "settle": tabletop.settle},
    }
    side: dict = {}
    table: dict[str, float] = defaultdict(float)
    _instrument(table, side)
    original_step = sapien.Scene.step
    counters = {"steps": 0}

    def counted_step(self):
        counters["steps"] += 1
        original_step(self)

    sapien.Scene.step = counted_step
    rows: dict[str, list] = {name: [] for name in sides}
    for i in range(-args.warmup, args.scenes):
        for name, functions in sides.items():
            side.update(functions)
            table.clear()
            counters["steps"] = 0
            start = time.perf_counter()
            built = tabletop.build_scene(config, config.seed + (1 if i < 0 else 0), abs(i))
            total = time.perf_counter() - start
            del built
            if i >= 0:
                row = {key: table[key] * 1000 for key, _ in STAGES}
                row |= {"settle": table["settle"] * 1000, "total": total * 1000}
                rows[name].append(row | {"steps": counters["steps"]})

    median = {
        name: {k: float(np.median([r[k] for r in side_rows])) for k in side_rows[0]}
        for name, side_rows in rows.items()
    }
    labels = [*STAGES, ("settle", "settle (physics steps)"), ("total", "build + settle")]
    print(f"{'median ms per scene':48} " + " ".join(f"{n:>16}" for n in sides))
    for key, label in [*labels, ("steps", "settle steps")]:
        print(f"{label:48} " + " ".join(f"{median[n][key]:16.2f}" for n in sides))
    before, now = (median[n]["total"] for n in sides)
    print(f"{'before ÷ now (build + settle)':48} {before / now:16.2f}")
    result = {
        "command": " ".join(sys.argv),
        "scenes": args.scenes,
        "load_average": os.getloadavg(),
        "cores": os.cpu_count(),
        "median_ms": median,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
