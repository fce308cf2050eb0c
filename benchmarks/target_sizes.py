"""How big the targets are in each camera of the default build: the detector-free check of
issue 39 (COCO calls an object of mask area 32x32 px or more "medium").

    .venv/bin/python benchmarks/target_sizes.py                # 100 default samples, seed 0
    .venv/bin/python benchmarks/target_sizes.py --samples 10   # quick

Each sample is produced as ``datagen build configs/grasp_tabletop.yaml`` stores it (same seed,
same bytes) and each target's mask area is counted in the stored ``seg.png`` of each camera.
Per camera: the median over samples of the median area of the targets the camera annotates
(area > 0), its minimum and 10th percentile, how many samples reach 32x32 px, and the share of
the sample's targets the camera annotates. Printed with the CPU; the figures do not depend on it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np
from machine import cpu_model  # benchmarks/machine.py

REPO = Path(__file__).resolve().parents[1]
COCO_MEDIUM = 32 * 32  # px


def target_areas(parts: dict[str, bytes], prefix: str) -> list[int]:
    """Mask area (px) of each target of the sample in the camera whose parts start ``prefix``."""
    seg = cv2.imdecode(np.frombuffer(parts[f"{prefix}seg.png"], np.uint8), cv2.IMREAD_UNCHANGED)
    ids = [record["instance_id"] for record in json.loads(parts["json"])["objects"]]
    return [int((seg == i).sum()) for i in ids]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=100)
    parser.add_argument("--config", default=str(REPO / "configs" / "grasp_tabletop.yaml"))
    args = parser.parse_args(argv)
    sys.path.insert(0, str(REPO))
    from datagen.config import load_config
    from datagen.families.grasp_tabletop.produce import produce

    config = load_config(args.config)
    cameras = {"workspace": ""} | ({"wrist": "wrist."} if config.render.wrist_camera else {})
    medians: dict[str, list[float]] = {name: [] for name in cameras}
    seen: dict[str, list[float]] = {name: [] for name in cameras}
    for index in range(args.samples):
        parts = produce(config, config.seed, index).parts
        for name, prefix in cameras.items():
            areas = target_areas(parts, prefix)
            shown = [a for a in areas if a > 0]
            medians[name].append(float(np.median(shown)) if shown else 0.0)
            seen[name].append(len(shown) / len(areas))
        print(f"\rsample {index + 1}/{args.samples}", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    size = f"{config.render.width}x{config.render.height}"
    print(f"{args.samples} samples of {Path(args.config).name} (seed {config.seed}), {size}")
    print(f"CPU: {cpu_model()}")
    print("camera     median target px (median / p10 / min)   samples >= 32x32   targets seen")
    for name in cameras:
        m = np.asarray(medians[name])
        reached = int((m >= COCO_MEDIUM).sum())
        print(
            f"{name:<10} {np.median(m):>12.0f} / {np.percentile(m, 10):>5.0f} / {m.min():>5.0f}"
            f"{reached:>21d}/{len(m)}{100 * np.mean(seen[name]):>14.1f} %"
        )
    for name in cameras:
        below = [i for i, v in enumerate(medians[name]) if v < COCO_MEDIUM]
        if 0 < len(below) <= 10:
            print(f"{name}: samples below 32x32: {below}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
