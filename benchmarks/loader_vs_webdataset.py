"""Loader throughput: ``datagen.stream`` and ``datagen.load`` against the webdataset library on
the same shards, decoding the same parts with the same decoder, in one run.

    .venv/bin/python benchmarks/loader_vs_webdataset.py                      # builds 300 samples
    .venv/bin/python benchmarks/loader_vs_webdataset.py --dataset datasets/grasp_tabletop

Each side yields every sample once per pass with rgb, depth, seg and semantic decoded to numpy
(cv2.imdecode, as datagen does) and the JSON parsed. Sides, each in one process and through a
torch DataLoader with 2 workers (batch_size=None): datagen.stream | datagen.load (map-style) |
webdataset.WebDataset(shards).decode(cv2 handler). A first untimed pass warms the page cache.
The ratio is datagen.stream ÷ webdataset in samples/s.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import webdataset as wds
from torch.utils.data import DataLoader

import datagen
from datagen.config import load_config
from datagen.pipeline.run import run_build

REPO = Path(__file__).resolve().parents[1]
IMAGES = ("rgb.png", "depth.png", "seg.png", "semantic.png")


def cv2_decoder(key: str, data: bytes):
    """webdataset handler: the images as datagen decodes them, JSON parsed."""
    ext = key.rsplit(".", 1)[0] if key.endswith(".png") else key
    if key.endswith(".png"):
        image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
        return cv2.cvtColor(image, cv2.COLOR_BGR2RGB) if ext == "rgb" else image
    if key == "json":
        return json.loads(data)
    return None


def _sides(root: Path):
    shards = [str(root / s["name"]) for s in datagen.dataset.loader.read_manifest(root)["shards"]]
    parts = {*IMAGES, "json"}

    def web():
        return wds.WebDataset(shards, shardshuffle=False, empty_check=False).decode(cv2_decoder)

    return {
        "datagen.stream": lambda: datagen.stream(root, parts=parts),
        "datagen.load (map-style)": lambda: datagen.load(root),
        "webdataset": web,
    }


def _time(make, workers: int) -> tuple[float, int]:
    dataset = make()
    iterable = DataLoader(dataset, batch_size=None, num_workers=workers) if workers else dataset
    start, n = time.perf_counter(), 0
    for item in iterable:
        n += 1
        assert item["rgb" if "rgb" in item else "rgb.png"] is not None
    return time.perf_counter() - start, n


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", help="an existing dataset (default: build one)")
    parser.add_argument("--num-samples", type=int, default=300)
    parser.add_argument("--repeat", type=int, default=3, help="timed passes per side (median)")
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/loader_vs_webdataset.json"))
    args = parser.parse_args()
    if args.dataset:
        root = Path(args.dataset)
    else:
        root = Path(tempfile.mkdtemp(prefix="datagen-loader-"))
        config = load_config(REPO / "configs/grasp_tabletop.yaml").replace(num_samples=args.num_samples)  # fmt: skip
        print(f"building {args.num_samples} samples into {root} ...", file=sys.stderr)
        run_build(config, root, os.cpu_count() or 1)
    rows: dict[str, dict] = {}
    print(f"{'side':28} {'workers':>7} {'samples':>7} {'samples/s':>10}")
    for workers in (0, 2):
        for name, make in _sides(root).items():
            _time(make, workers)  # warm-up pass: page cache, worker start-up paths
            runs = [_time(make, workers) for _ in range(args.repeat)]
            seconds = float(np.median([s for s, _ in runs]))
            n = runs[0][1]
            rows[f"{name}, {workers} workers"] = {
                "samples": n,
                "samples_per_s": round(n / seconds, 1),
            }
            print(f"{name:28} {workers:>7} {n:>7} {n / seconds:>10.1f}", flush=True)
    ratios = {
        f"datagen.stream / webdataset, {w} workers": round(
            rows[f"datagen.stream, {w} workers"]["samples_per_s"]
            / rows[f"webdataset, {w} workers"]["samples_per_s"],
            3,
        )
        for w in (0, 2)
    }
    for name, value in ratios.items():
        print(f"ratio {name}: {value}")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"command": " ".join(sys.argv), "dataset": str(root), "rows": rows, "ratios": ratios}, indent=2))  # fmt: skip
    if not args.dataset:  # the set this run built for itself
        shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
