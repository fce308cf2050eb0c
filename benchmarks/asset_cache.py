"""Users' meshes: time to the first sample with a cold and with a warm cache of convex
decompositions, side by side in one run (issue 40, item 4).

    .venv/bin/python benchmarks/asset_cache.py                    # 12 meshes, 2 workers, 4 samples
    .venv/bin/python benchmarks/asset_cache.py --before 2ecc81a   # and the same build at a commit
    .venv/bin/python benchmarks/asset_cache.py --at HEAD          # the commit, not the work tree

The folder holds twelve real meshes: robosuite's six object meshes from the picture library
(``datagen library install``, source ``robosuite-objects``) and six object meshes that ship
with ManiSkill, each in a class folder. Each build is the real command, ``datagen -v build
CONFIG --out TMP --num-samples N --workers 2 --no-preview`` with ``objects.source: folder``
(otherwise the default config, 640x480), stamped line by line as ``benchmarks/startup.py``
does. Every build runs with ``XDG_CACHE_HOME`` a temporary folder of this run, first filled by
one untimed build with procedural objects (Mesa's shaders, the BRDF table, the robot's
simplified meshes), so that the sides differ only in the decompositions:

| side | what it finds |
|---|---|
| cold | no decomposition cached: the workers decompose the twelve meshes between them |
| warm | the same command again: every decomposition cached |
| REV | (``--before REV``) datagen at REV, from ``git archive``; before the cache, every worker and the coordinator decomposed every mesh |

``--at REV`` times cold and warm with datagen at REV (``git archive``) instead of the working
tree: a tree others are editing may not build.

Columns: first durable s (the command's start to ``1/N durable``), wall s (to its exit:
manifest, card), CPU s (every process of the command), and the decompositions each kind of
process reported (``N decomposed here``: the log line of ``mesh_library.load_library``; ``-``
where no process logged it, as at a commit before it). The CPU model, the load average and the
figures are printed and written to ``benchmarks/results/asset_cache.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mani_skill
import yaml
from machine import cpu_model  # benchmarks/machine.py

from datagen.library.catalogue import library_root

REPO = Path(__file__).resolve().parents[1]
ROBOSUITE = ("bottle", "bread", "can", "cereal", "lemon", "milk")  # robosuite-objects/<n>/<n>.stl
MANISKILL = {  # class folder: the mesh's path in the mani_skill package
    "apple": "envs/tasks/humanoid/assets/apple_1.glb",
    "bowl": "envs/tasks/humanoid/assets/frl_apartment_bowl_07.glb",
    "bridge": "envs/tasks/fmb/assets/green_bridge.glb",
    "u_block": "envs/tasks/fmb/assets/purple_u.glb",
    "beaker": "assets/deformable_manipulation/beaker.glb",
    "flask": "assets/deformable_manipulation/bottle.glb",
}
PROGRESS = re.compile(r"datagen: (\d+)/(\d+) durable")
COLUMNS = {  # key: heading
    "first_durable_s": "first durable s",
    "wall_s": "wall s",
    "cpu_s": "CPU s",
    "decomposed_by_workers": "decomposed: workers",
    "decomposed_by_coordinator": "coordinator",
}
DECOMPOSED = re.compile(r"^(\[worker \d+\] )?INFO .*: (\d+) meshes, (\d+) decomposed here")


def mesh_folder(into: Path) -> Path:
    """The twelve meshes, copied into ``into/<class>/``."""
    robosuite = library_root() / "robosuite-objects"
    if not robosuite.is_dir():
        raise SystemExit(f"{robosuite}: not installed; run `datagen library install` first")
    sources = {name: robosuite / name / f"{name}.stl" for name in ROBOSUITE}
    package = Path(mani_skill.__file__).parent
    sources |= {name: package / path for name, path in MANISKILL.items()}
    for name, source in sources.items():
        (into / name).mkdir(parents=True)
        shutil.copyfile(source, into / name / source.name)
    return into


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def one_build(tree: Path, config: Path, samples: int, cache: Path) -> dict[str, float]:
    """One build with ``tree``'s datagen; seconds from the command's start."""
    out = Path(tempfile.mkdtemp(prefix="asset-cache-"))
    command = [
        sys.executable,
        "-m",
        "datagen.cli",
        "-v",
        "build",
        str(config),
        "--out",
        str(out / "ds"),
        "--num-samples",
        str(samples),
        "--workers",
        "2",
        "--no-preview",
    ]
    env = os.environ | {
        "DATAGEN_PROGRESS_INTERVAL_S": "0",
        "DATAGEN_LOG_LEVEL": "INFO",  # the workers' "decomposed here" lines
        "PYTHONPATH": str(tree),
        "XDG_CACHE_HOME": str(cache),
    }
    marks: dict[str, float] = {}
    cpu_before, start = _children_cpu(), time.monotonic()
    with subprocess.Popen(
        command,
        cwd=tree,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        stdin=subprocess.DEVNULL,
        text=True,
    ) as process:
        assert process.stdout is not None
        lines = []
        for line in process.stdout:
            lines.append(line)
            if (match := PROGRESS.search(line)) and int(match[1]) >= 1:
                marks.setdefault("first_durable_s", round(time.monotonic() - start, 1))
            if match := DECOMPOSED.search(line):
                key = "decomposed_by_workers" if match[1] else "decomposed_by_coordinator"
                marks[key] = marks.get(key, 0) + int(match[3])
        code = process.wait()
    marks["wall_s"] = round(time.monotonic() - start, 1)
    marks["cpu_s"] = round(_children_cpu() - cpu_before, 1)
    shutil.rmtree(out, ignore_errors=True)
    if code != 0 or "first_durable_s" not in marks:
        raise SystemExit(f"the build with {tree} failed ({code}):\n{''.join(lines)[-3000:]}")
    return marks


def _archive(rev: str, into: Path) -> Path:
    """datagen at ``rev``, unpacked into ``into`` (no worktree: the repository is shared)."""
    into.mkdir()
    archive = subprocess.run(
        ["git", "-C", str(REPO), "archive", rev, "datagen"], capture_output=True, check=True
    )
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive.stdout, check=True)
    return into


def _commit(rev: str) -> str:
    done = subprocess.run(
        ["git", "-C", str(REPO), "rev-parse", "--short", rev], capture_output=True, text=True
    )
    return done.stdout.strip()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=4, help="samples per build")
    parser.add_argument("--before", metavar="REV", help="also time the build at this commit")
    parser.add_argument("--at", metavar="REV", help="time datagen at this commit, not the tree")
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/asset_cache.json"))
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="asset-cache-bench-"))
    load_at_start = os.getloadavg()
    try:
        folder = mesh_folder(work / "meshes")
        config = work / "config.yaml"
        config.write_text(
            yaml.safe_dump({"objects": {"source": "folder", "assets_dir": str(folder)}})
        )
        procedural = work / "procedural.yaml"
        procedural.write_text("{}\n")
        cache = work / "cache"
        now = _archive(args.at, work / "now") if args.at else REPO
        one_build(now, procedural, 1, cache)  # untimed: the renderer's caches
        rows = {"cold": one_build(now, config, args.samples, cache)}
        rows["warm"] = one_build(now, config, args.samples, cache)
        if args.before:
            tree = _archive(args.before, work / "before")
            rows[args.before] = one_build(tree, config, args.samples, cache)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    machine = {
        "cpu_model": cpu_model(),
        "cores": os.cpu_count(),
        "load_average_1_5_15_min": {"start": load_at_start, "end": os.getloadavg()},
    }
    commit = _commit(args.at or "HEAD") + ("" if args.at else " and the working tree")
    print(f"machine: {machine['cores']} cores, {machine['cpu_model']}")
    print(f"load average (1 min) at start {load_at_start[0]:.2f}, at end {os.getloadavg()[0]:.2f}")
    print(
        f"datagen at {commit}: datagen -v build CONFIG --num-samples {args.samples} --workers 2 "
        f"--no-preview, objects.source: folder, {len(ROBOSUITE) + len(MANISKILL)} meshes"
    )
    print(f"{'side':>8} " + " ".join(f"{heading:>20}" for heading in COLUMNS.values()))
    for name, row in rows.items():
        print(f"{name:>8} " + " ".join(f"{row.get(key, '-'):>20}" for key in COLUMNS))
    result = {
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
        "commit": commit,
        "machine": machine,
        "rows": rows,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
