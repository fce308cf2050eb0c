"""Does the randomisation transfer? Train one small segmentation net per randomisation level
and score each on one appearance domain that none of them saw.

    .venv/bin/python benchmarks/dr_ablation.py                # 3 x 480 frames, 3 seeds, ~10 min
    .venv/bin/python benchmarks/dr_ablation.py --scenes 40 --test-scenes 20 --epochs 6  # quick

Training sets, equal sizes, the same seed and sample indices, built by the real pipeline
(``run_build``: workers, MQTT, writer, shards) at 160x120 with ``render.views`` views per scene:

- (a) ``flat``: ``configs/grasp_flat.yaml``, today's flat colours and primitives;
- (b) ``+textures+backgrounds``: (a) with procedural textures and randomised surroundings;
- (c) ``+distractors+household+effects``: the default config (everything on).

Every training set uses only the *training* texture families and lighting ranges below. The
held-out test set (its own seed) uses the other texture families, lighting outside the
training ranges, and everything else on: the appearance domain none of the models saw.

The net (the notebook ``notebooks/train_segmentation.ipynb``'s dilated FCN, a little wider) sees
80x60 colour images and predicts four classes: ``other`` (floor, walls, robot, background,
distractors), ``table``, ``tray``, ``object`` (any grasp target). Reported: per-class IoU and
mIoU on the held-out set for each model, the seeds and sizes, build and training times. Results
go to ``benchmarks/results/dr_ablation.json``.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # workers' BLAS threads busy-wait otherwise

REPO = Path(__file__).resolve().parents[1]
ABLATION_CLASSES = ("other", "table", "tray", "object")
INPUT_SIZE = (80, 60)  # width, height seen by the net
TRAIN_TEXTURES = ["noise", "stripes", "checker"]
HELD_OUT_TEXTURES = ["marble", "grain", "speckle"]
TRAIN_LIGHTING = {"ambient": [0.15, 0.45], "intensity": [0.6, 2.0]}
HELD_OUT_LIGHTING = {"ambient": [0.05, 0.15], "intensity": [2.0, 3.5]}


def _merge(base: dict, overrides: dict) -> dict:
    merged = copy.deepcopy(base)
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = _merge(merged[key], value)
        else:
            merged[key] = value
    return merged


def variant_configs(scenes: int, test_scenes: int, views: int) -> dict[str, dict]:
    """Config dicts of the three training sets and the held-out test set (validated later)."""
    from datagen.config.yaml_file import read_yaml

    flat = read_yaml(REPO / "configs/grasp_flat.yaml")
    default = read_yaml(REPO / "configs/grasp_tabletop.yaml")
    size = {"render": {"width": 160, "height": 120, "views": views, "shadow_map_size": 512}}
    train = {"lighting": TRAIN_LIGHTING, "materials": {"texture_families": TRAIN_TEXTURES}}
    textures_backgrounds = {
        "materials": _merge(default["materials"], {"texture_families": TRAIN_TEXTURES}),
        "background": default["background"],
    }
    held_out = {
        "lighting": HELD_OUT_LIGHTING,
        "materials": {"texture_families": HELD_OUT_TEXTURES},
    }
    return {
        "a_flat": _merge(
            flat, size | {"num_samples": scenes, "seed": 1, "lighting": TRAIN_LIGHTING}
        ),
        "b_textures_backgrounds": _merge(
            _merge(flat, textures_backgrounds), size | {"num_samples": scenes, "seed": 1}
        ),
        "c_everything": _merge(_merge(default, train), size | {"num_samples": scenes, "seed": 1}),
        "held_out_test": _merge(
            _merge(default, held_out), size | {"num_samples": test_scenes, "seed": 99}
        ),
    }


def build(name: str, data: dict, root: Path, workers: int) -> tuple[Path, float]:
    from datagen.config import config_from_dict
    from datagen.pipeline.run import run_build

    config = config_from_dict(data, source=f"dr_ablation:{name}")
    out = root / name
    start = time.perf_counter()
    run_build(config, out, workers=workers)
    return out, time.perf_counter() - start


def frames(dataset: Path):
    """(N, 3, H, W) float images and (N, H, W) ablation class maps of every view."""
    import cv2
    import numpy as np
    import torch

    import datagen

    classes = datagen.dataset.loader.read_manifest(dataset)["classes"]
    lut = np.zeros(256, np.int64)  # stored semantic id -> ablation class
    for i, name in enumerate(classes):
        if name in ("table", "tray"):
            lut[i] = ABLATION_CLASSES.index(name)
        elif name not in ("background", "floor", "wall", "robot", "distractor"):
            lut[i] = ABLATION_CLASSES.index("object")
    images, targets = [], []
    for item in datagen.load(dataset):
        for view in [item, *item.get("views", {}).values()]:  # workspace, view1, ...
            images.append(cv2.resize(view["rgb"], INPUT_SIZE, interpolation=cv2.INTER_AREA))
            semantic = cv2.resize(view["semantic"], INPUT_SIZE, interpolation=cv2.INTER_NEAREST)
            targets.append(lut[semantic])
    x = torch.from_numpy(np.stack(images)).permute(0, 3, 1, 2).float() / 255.0
    return x, torch.from_numpy(np.stack(targets))


def segmentation_net():
    from torch import nn

    return nn.Sequential(
        nn.Conv2d(3, 24, 3, padding=1), nn.BatchNorm2d(24), nn.ReLU(),
        nn.Conv2d(24, 32, 3, padding=2, dilation=2), nn.BatchNorm2d(32), nn.ReLU(),
        nn.Conv2d(32, 32, 3, padding=4, dilation=4), nn.BatchNorm2d(32), nn.ReLU(),
        nn.Conv2d(32, 32, 3, padding=8, dilation=8), nn.BatchNorm2d(32), nn.ReLU(),
        nn.Conv2d(32, len(ABLATION_CLASSES), 1),
    )  # fmt: skip


def train(x, y, epochs: int, seed: int):
    import torch
    from torch import nn

    torch.manual_seed(seed)
    net = segmentation_net()
    optimiser = torch.optim.Adam(net.parameters(), lr=3e-3)
    generator = torch.Generator().manual_seed(seed)
    losses = []
    for _ in range(epochs):
        order = torch.randperm(len(x), generator=generator)
        total = 0.0
        for batch in order.split(16):
            loss = nn.functional.cross_entropy(net(x[batch]), y[batch])
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            total += loss.item() * len(batch)
        losses.append(round(total / len(x), 4))
    return net.eval(), losses


def iou(net, x, y) -> dict[str, float]:
    import torch

    with torch.no_grad():
        predicted = torch.cat([net(b).argmax(1) for b in x.split(64)])
    scores = {}
    for c, name in enumerate(ABLATION_CLASSES):
        union = ((predicted == c) | (y == c)).sum().item()
        scores[name] = round(100 * ((predicted == c) & (y == c)).sum().item() / union, 2)
    scores["mIoU"] = round(sum(scores[n] for n in ABLATION_CLASSES) / len(ABLATION_CLASSES), 2)
    return scores


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=120, help="scenes per training set")
    parser.add_argument("--test-scenes", type=int, default=60)
    parser.add_argument("--views", type=int, default=4, help="views per scene")
    parser.add_argument("--epochs", type=int, default=12)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=[0, 1, 2], help="training seeds (weights, batches)"
    )
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/dr_ablation.json"))
    args = parser.parse_args()

    import torch

    torch.set_num_threads(os.cpu_count() or 1)
    configs = variant_configs(args.scenes, args.test_scenes, args.views)
    result: dict = {"command": " ".join(sys.argv), "cores": os.cpu_count(), "models": {}}
    with tempfile.TemporaryDirectory(prefix="dr-ablation-") as tmp:
        test_dir, test_build_s = build(
            "held_out_test", configs.pop("held_out_test"), Path(tmp), args.workers
        )
        test_x, test_y = frames(test_dir)
        print(f"held-out test set: {len(test_x)} frames, built in {test_build_s:.0f} s", flush=True)
        for name, data in configs.items():
            dataset, build_s = build(name, data, Path(tmp), args.workers)
            x, y = frames(dataset)
            runs = []
            for seed in args.seeds:  # one model per training seed: the spread is large
                start = time.perf_counter()
                net, losses = train(x, y, args.epochs, seed)
                runs.append({"seed": seed, "train_s": round(time.perf_counter() - start, 1),
                             "losses": losses, "held_out_iou": iou(net, test_x, test_y)})  # fmt: skip
            mean = {
                c: round(sum(r["held_out_iou"][c] for r in runs) / len(runs), 2)
                for c in (*ABLATION_CLASSES, "mIoU")
            }
            result["models"][name] = {
                "frames": len(x), "build_s": round(build_s, 1), "runs": runs, "mean_iou": mean,
            }  # fmt: skip
            per_seed = ", ".join(f"{r['held_out_iou']['mIoU']:.1f}" for r in runs)
            print(f"{name:24} {len(x)} frames, built {build_s:.0f} s, "
                  f"held-out mIoU per seed {per_seed}, mean {mean['mIoU']:.1f}", flush=True)  # fmt: skip
    models = result["models"]
    result["test_frames"] = len(test_x)
    gains = [
        c["held_out_iou"]["mIoU"] - a["held_out_iou"]["mIoU"]
        for a, c in zip(models["a_flat"]["runs"], models["c_everything"]["runs"], strict=True)
    ]
    result["c_minus_a_mIoU_per_seed"] = [round(g, 2) for g in gains]
    result["c_minus_a_mIoU"] = round(sum(gains) / len(gains), 2)
    print(f"\nheld-out IoU, mean over training seeds {args.seeds}")
    print(f"{'model':24} " + " ".join(f"{c:>7}" for c in (*ABLATION_CLASSES, "mIoU")))
    for name, row in models.items():
        scores = row["mean_iou"]
        print(f"{name:24} " + " ".join(f"{scores[c]:7.1f}" for c in (*ABLATION_CLASSES, "mIoU")))
    shown = ", ".join(f"{g:+.1f}" for g in gains)
    print(f"(c) - (a) on the held-out domain: {result['c_minus_a_mIoU']:+.1f} mIoU points on "
          f"average (per seed {shown}; target >= +10)")  # fmt: skip
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
