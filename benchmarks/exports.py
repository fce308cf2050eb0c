"""What each export costs: samples/s and peak memory per format on 2,000-sample datasets, in one run.

    .venv/bin/python benchmarks/exports.py                   # 2,000 samples per dataset
    .venv/bin/python benchmarks/exports.py --samples 200     # quick

Three datasets are made: grasp frames (``configs/grasp_tabletop.yaml``, every randomiser, at
320x240), a filmed grasp campaign (``configs/grasp_campaign.yaml`` at 160x120, workspace and
wrist cameras filmed at 5 Hz) and navigation episodes (``configs/nav_corridor.yaml``, 160x120).
Each is built for real with ``--base`` samples, then grown to ``--samples`` by writing those
samples again under new keys (the same parts, the metadata's key and index renumbered; shards
and manifest written as the writer writes them): an export's work per sample does not depend on
which sample it is, and 2,000 real attempts would take an hour on two cores. Every export runs
in a fresh process (``datagen export DIR --to NAME``), one after the other, on the grown dataset
and on the base one; reported: samples/s on the grown one, the peak resident memory of each
process (``ru_maxrss`` of the child) and their ratio (about 1 when memory does not grow with
the dataset), and the exported size. Results go to ``benchmarks/results/exports.json``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
DATAGEN = [sys.executable, "-m", "datagen.cli"]
DATASETS = {  # name -> (command, config overrides on top of the file, formats)
    "frames": (
        ["build", "configs/grasp_tabletop.yaml"], {"render": {"width": 320, "height": 240}},
        ["coco", "hdf5", "yolo", "bop", "pointcloud"],
    ),
    "campaign": (
        ["campaign", "grasp", "configs/grasp_campaign.yaml"],
        {"render": {"width": 160, "height": 120, "wrist_camera": True},
         "campaign": {"record_hz": 5, "frame_hz": 5, "post_grasp_frame": False}},
        ["lerobot", "robomimic", "hdf5", "yolo", "bop"],
    ),
    "navigation": (
        ["build", "configs/nav_corridor.yaml"], {"render": {"width": 160, "height": 120}},
        ["lerobot", "robomimic", "hdf5", "yolo"],
    ),
}  # fmt: skip


def _merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        out[key] = _merge(base.get(key, {}), value) if isinstance(value, dict) else value
    return out


def _run(command: list[str]) -> float:
    """Wall seconds of a datagen command that must succeed."""
    start = time.perf_counter()
    done = subprocess.run([*DATAGEN, *command], cwd=REPO, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    return time.perf_counter() - start


def _peak_of_one(command: list[str]) -> tuple[float, float]:
    """(wall seconds, peak resident MiB) of a datagen command that must succeed, run by a fresh
    child process so that the peak (its children's ``ru_maxrss``) is this command's alone."""
    code = (
        "import resource, subprocess, sys, time, json\n"
        "t = time.perf_counter()\n"
        "r = subprocess.run(sys.argv[1:], capture_output=True, text=True)\n"
        "w = time.perf_counter() - t\n"
        "sys.stderr.write(r.stderr[-3000:]) if r.returncode else None\n"
        "print(json.dumps([r.returncode, w, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss]))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, *DATAGEN, *command], cwd=REPO, capture_output=True, text=True
    )
    code_, wall, peak_kib = json.loads(done.stdout.strip().splitlines()[-1])
    if code_ != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    return wall, peak_kib / 1024


def _grow(base: Path, out: Path, samples: int) -> None:
    """``out``: ``samples`` samples, the base dataset's repeated under new keys."""
    from datagen.dataset.loader import load
    from datagen.dataset.manifest import read_manifest
    from datagen.sample import Sample, sample_key
    from datagen.shards import keys_sha256, write_json_durably
    from datagen.writer.journal import journal_path
    from datagen.writer.shard_writer import ShardWriter

    source, manifest = load(base), read_manifest(base)
    out.mkdir(parents=True)
    keys = []
    with ShardWriter(out, "0", 100) as sink:
        for index in range(samples):
            raw = dict(source.raw(index % len(source)))
            meta = json.loads(raw["json"])
            meta["key"], meta["index"] = sample_key(index), index
            raw["json"] = json.dumps(meta, separators=(",", ":")).encode()
            sink.write(Sample(index, raw))
            keys.append(sample_key(index))
    for name in ("exports", "shards", "samples", "keys_sha256"):
        manifest.pop(name, None)
    manifest |= {
        "samples": samples,
        "num_samples": samples,
        "shards": [s.to_json() for s in sink.shards],
        "keys_sha256": keys_sha256(keys),
    }
    write_json_durably(out, manifest)
    journal_path(out, "0").unlink()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2000, help="samples per dataset")
    parser.add_argument("--base", type=int, default=20, help="samples built for real per dataset")
    parser.add_argument("--only", default="", help="comma-separated datasets (default: all)")
    args = parser.parse_args()
    results: dict[str, dict] = {"samples": args.samples, "base": args.base, "formats": {}}
    with tempfile.TemporaryDirectory(prefix="datagen-exports-bench-") as tmp:
        for name, (command, overrides, formats) in DATASETS.items():
            if args.only and name not in args.only.split(","):
                continue
            config = _merge(yaml.safe_load((REPO / command[-1]).read_text()), overrides)
            config_path = Path(tmp) / f"{name}.yaml"
            config_path.write_text(yaml.safe_dump(config))
            base, grown = Path(tmp) / f"{name}-base", Path(tmp) / name
            flag = "--attempts" if command[0] == "campaign" else "--num-samples"
            build = [*command[:-1], str(config_path), "--out", str(base), flag, str(args.base)]
            quiet = ["--no-preview"] if command[0] == "build" else []  # a campaign draws none
            wall = _run([*build, "--workers", "2", *quiet])
            print(f"{name}: {args.base} samples built in {wall:.1f} s", flush=True)
            _grow(base, grown, args.samples)
            for fmt in formats:
                _, small_peak = _peak_of_one(["export", str(base), "--to", fmt])
                wall, peak = _peak_of_one(["export", str(grown), "--to", fmt])
                exported = json.loads((grown / "manifest.json").read_text())["exports"][fmt]
                row = {
                    "samples_per_s": round(args.samples / wall, 2),
                    "seconds": round(wall, 2),
                    "peak_rss_mib": round(peak, 1),
                    "peak_rss_mib_base": round(small_peak, 1),
                    "peak_ratio": round(peak / small_peak, 3),
                    "exported_mib": round(exported["bytes"] / 2**20, 1),
                }
                results["formats"][f"{name}/{fmt}"] = row
                print(
                    f"{name:10s} {fmt:10s} {row['samples_per_s']:8.2f} samples/s "
                    f"{row['seconds']:8.1f} s  peak {row['peak_rss_mib']:7.1f} MiB "
                    f"(x{row['peak_ratio']:.2f} the peak at {args.base})  "
                    f"{row['exported_mib']:8.1f} MiB written",
                    flush=True,
                )
                shutil.rmtree(grown / exported["path"], ignore_errors=True)
            shutil.rmtree(grown)
            shutil.rmtree(base)
    out = REPO / "benchmarks" / "results" / "exports.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(results, indent=1))
    print(f"results: {out.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
