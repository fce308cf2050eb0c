"""Does the randomisation transfer? Train one small segmentation net per training set and
training seed, and score each on test domains built from sources no training set drew.

    .venv/bin/python benchmarks/dr_ablation.py               # 8 sets x 480 frames, 6 seeds
    .venv/bin/python benchmarks/dr_ablation.py --scenes 30 --test-scenes 15 --epochs 4 --seeds 0 1

On the 2-core machine the builds take about 8 minutes; a training takes about 4 minutes there
with ``--precision bf16`` (bfloat16 convolutions, for CPUs with AVX-512 BF16; 16 minutes in
float32) and a few seconds on a GPU. The frames can be built here and the nets trained elsewhere
(only torch and numpy needed there):

    .venv/bin/python benchmarks/dr_ablation.py --frames-dir benchmarks/results/dr_frames --build-only
    python3 benchmarks/dr_ablation.py --frames-dir benchmarks/results/dr_frames --device cuda
    .venv/bin/python benchmarks/dr_ablation.py --frames-dir benchmarks/results/dr_frames --precision bf16 --only a_flat b_textures_room c_default

Training sets, equal sizes, the same seed and sample indices, built by the real pipeline
(``run_build``: workers, MQTT, writer, shards) at 160x120 with ``render.views`` views per scene,
all with the training texture families, lighting within the training band, photographs of
the training sources only (``photos.sources``), and the same camera for every set and test
domain: the close-up of ``configs/grasp_closeup.yaml`` with its arm folded back out of view and
no wrist camera (from the default camera behind the arm the objects are a pixel or two at the
net's 80x60, and a set that differs in viewpoint would measure the viewpoint, not the
appearance; so issue 39's wrist camera over the tray left these frames as they were):

- ``a_flat``: ``configs/grasp_flat.yaml`` (flat colours, primitives, nothing around);
- ``b_textures_room``: (a) with procedural textures and the room (no photographs);
- ``c_default``: the default config, everything on;
- ``c_no_<randomiser>``: (c) without one of issue 26's randomisers each (photographs on
  surfaces, photographs on the walls, flying distractors, the wider lighting, class-independent
  colours): what each adds, given the rest.

Test domains (their own seeds), each from sources never used in training:

- ``procedural``: the held-out texture families and lighting outside the training band;
- ``photos``: photographs of the held-out library source (``skimage-data``) on 90 % of the
  surfaces, every wall and every flying card, the library's real object meshes (robosuite's,
  through ``objects.source: folder``) instead of procedural shapes, the held-out texture
  families and the lighting outside the training band.

The net (a dilated FCN) sees 80x60 colour images and predicts ``other`` (floor, walls, robot,
gripper, background, distractors), ``table``, ``tray``, ``object``. It trains with AdamW and a
cosine schedule, each batch mirrored and jittered in brightness and contrast (the same for every
set; ``--no-augment`` turns it off); one model per (training set, seed). Printed per test
domain: mean IoU over the seeds ± its standard error, and an image-blind baseline (each pixel's
most common class over the training set (c): what a net that ignores the image scores). Results
go to ``benchmarks/results/dr_ablation.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

from dr_transfer.building import build
from dr_transfer.frames import SEGMENTATION_CLASSES, load_frames, read_frames, save_frames
from dr_transfer.scoring import blind_prediction, iou, mean_se, shown
from dr_transfer.training import predict, train
from dr_transfer.variants import (
    HELD_OUT_LIGHTING,
    HELD_OUT_TEXTURES,
    TEST_SEED,
    TRAINING_SETS,
    held_out_photos,
    merged,
    real_meshes,
    repo_config,
    training_sets,
)

os.environ.setdefault("OMP_NUM_THREADS", "1")  # workers' BLAS threads busy-wait otherwise

REPO = Path(__file__).resolve().parents[1]
INPUT_SIZE = (80, 60)  # width, height seen by the net
TARGET_GAIN, TARGET_OVER_BLIND, TARGET_SE = 15.0, 15.0, 2.0  # mIoU points, photo domain


def variant_configs(scenes: int, test_scenes: int, views: int) -> tuple[dict, dict]:
    """Config dicts of the training sets and of the test domains (validated when built)."""
    default = repo_config("grasp_tabletop.yaml")
    closeup = repo_config("grasp_closeup.yaml")
    size = {
        "render": {
            "width": 160,
            "height": 120,
            "views": views,
            "shadow_map_size": 512,
            "wrist_camera": False,
        },
        "camera": closeup["camera"],
        "robot": closeup["robot"],
    }
    test = size | {
        "num_samples": test_scenes,
        "seed": TEST_SEED,
        "lighting": HELD_OUT_LIGHTING,
        "materials": {"texture_families": HELD_OUT_TEXTURES},
    }
    tests = {
        "procedural": merged(merged(default, test), {"photos": {"enabled": False}}),
        "photos": merged(merged(default, test), held_out_photos(default) | real_meshes()),
    }
    return training_sets(size, scenes), tests


def segmentation_net(channels: int = 32):
    from torch import nn

    c = channels
    return nn.Sequential(
        nn.Conv2d(3, c, 3, padding=1), nn.BatchNorm2d(c), nn.ReLU(),
        nn.Conv2d(c, c, 3, padding=1), nn.BatchNorm2d(c), nn.ReLU(),
        nn.Conv2d(c, c, 3, padding=2, dilation=2), nn.BatchNorm2d(c), nn.ReLU(),
        nn.Conv2d(c, c, 3, padding=4, dilation=4), nn.BatchNorm2d(c), nn.ReLU(),
        nn.Conv2d(c, c, 3, padding=8, dilation=8), nn.BatchNorm2d(c), nn.ReLU(),
        nn.Conv2d(c, c, 3, padding=16, dilation=16), nn.BatchNorm2d(c), nn.ReLU(),
        nn.Conv2d(c, len(SEGMENTATION_CLASSES), 1),
    )  # fmt: skip


TEST_DOMAINS = ("procedural", "photos")
SETS = TRAINING_SETS


def dataset_frames(name: str, args, configs, tmp: Path):
    """The frames of one set: read from ``--frames-dir`` if saved there, else built (and
    saved there when it is given); (x, y, seconds it took to build or None)."""
    saved = Path(args.frames_dir) / f"{name}.npz" if args.frames_dir else None
    if saved and saved.is_file():
        frames = load_frames(saved)
        return frames.float_images(), frames.classes, None
    if configs is None:
        configs = variant_configs(args.scenes, args.test_scenes, args.views)
    data = {**configs[0], **configs[1]}[name.removeprefix("test_")]
    built = build(f"dr_ablation:{name}", data, tmp / name, args.workers)
    build_s = built.seconds if built else None
    frames = read_frames(tmp / name, INPUT_SIZE)
    if saved:
        save_frames(frames, saved)
    return frames.float_images(), frames.classes, build_s


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=120, help="scenes per training set")
    parser.add_argument("--test-scenes", type=int, default=60, help="scenes per test domain")
    parser.add_argument("--views", type=int, default=4, help="views per scene")
    parser.add_argument("--epochs", type=int, default=30)
    parser.add_argument("--channels", type=int, default=64, help="the net's width")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(6)), help="training seeds")  # fmt: skip
    parser.add_argument("--only", nargs="+", choices=SETS, help="train only these sets (default: all)")  # fmt: skip
    parser.add_argument("--frames-dir", help="keep each set's frames here (npz), and read them back instead of building again")  # fmt: skip
    parser.add_argument("--build-only", action="store_true", help="build and save the frames (--frames-dir), train nothing")  # fmt: skip
    parser.add_argument("--device", default="cpu", help="torch device that trains (cpu, cuda)")
    parser.add_argument("--precision", choices=("fp32", "bf16"), default="fp32", help="bf16: autocast the convolutions (4x faster on an AVX-512 BF16 CPU)")  # fmt: skip
    parser.add_argument("--no-augment", dest="augment", action="store_false", help="train without mirroring and brightness/contrast jitter")  # fmt: skip
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/dr_ablation.json"))
    args = parser.parse_args()

    import torch

    torch.set_num_threads(os.cpu_count() or 1)
    device = torch.device(args.device)
    names = [n for n in SETS if not args.only or n in args.only]
    result: dict = {"command": " ".join(sys.argv), "cores": os.cpu_count(), "seeds": args.seeds,
                    "device": str(device), "precision": args.precision, "augment": args.augment,
                    "models": {}, "tests": {}}  # fmt: skip
    configs = None
    with tempfile.TemporaryDirectory(prefix="dr-ablation-") as tmp:
        test_data = {}
        for name in TEST_DOMAINS:
            x, y, build_s = dataset_frames(f"test_{name}", args, configs, Path(tmp))
            test_data[name] = (x.to(device), y.to(device))
            result["tests"][name] = {"frames": len(x), "build_s": build_s}
            print(f"test domain {name:12} {len(x)} frames", flush=True)
        for name in names:
            x, y, build_s = dataset_frames(name, args, configs, Path(tmp))
            if args.build_only:
                print(f"{name:22} {len(x)} frames, built in {build_s or 0:.0f} s", flush=True)
                continue
            x, y = x.to(device), y.to(device)
            if name == "c_default":
                result["models"]["blind"] = {"scores": {
                    t: [iou(blind_prediction(y, len(ty)), ty)] * len(args.seeds)
                    for t, (_, ty) in test_data.items()}}  # fmt: skip
            runs: dict[str, list] = {t: [] for t in test_data}
            train_s = []
            for seed in args.seeds:
                start = time.perf_counter()
                make_net = partial(segmentation_net, args.channels)
                net, _ = train(x, y, make_net, args.epochs, seed, args.augment, args.precision)
                train_s.append(time.perf_counter() - start)
                for t, (tx, ty) in test_data.items():
                    runs[t].append(iou(predict(net, tx, args.precision), ty))
            result["models"][name] = {"frames": len(x), "build_s": build_s,
                                      "train_s": round(statistics.fmean(train_s), 1), "scores": runs}  # fmt: skip
            per_domain = "  ".join(f"{t} {shown([r['mIoU'] for r in runs[t]])}" for t in runs)
            print(
                f"{name:22} {len(x)} frames, trained {statistics.fmean(train_s):.0f} s/seed: {per_domain}",
                flush=True,
            )
    if args.build_only:
        return 0
    report(result, list(test_data))
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=1))
    return 0


def report(result: dict, domains: list[str]) -> None:
    models = result["models"]
    print(f"\nmIoU on each test domain, mean ± standard error over training seeds {result['seeds']}")  # fmt: skip
    print(f"{'model':22} " + " ".join(f"{d:>14}" for d in domains))
    for name, row in models.items():
        print(
            f"{name:22} "
            + " ".join(f"{shown([r['mIoU'] for r in row['scores'][d]]):>14}" for d in domains)
        )
    if "a_flat" not in models or "c_default" not in models:
        return
    summary = {}
    for d in domains:
        c = [r["mIoU"] for r in models["c_default"]["scores"][d]]
        a = [r["mIoU"] for r in models["a_flat"]["scores"][d]]
        blind = models["blind"]["scores"][d][0]["mIoU"]
        gain, gain_se = mean_se([ci - ai for ci, ai in zip(c, a, strict=True)])  # paired by seed
        summary[d] = {"c_minus_a": round(gain, 2), "c_minus_a_se": round(gain_se, 2),
                      "c_minus_blind": round(statistics.fmean(c) - blind, 2),
                      "c_se": round(mean_se(c)[1], 2), "a_se": round(mean_se(a)[1], 2)}  # fmt: skip
        print(f"{d}: (c) - (a) = {gain:+.1f} ± {gain_se:.1f} (per seed "
              + ", ".join(f"{ci - ai:+.1f}" for ci, ai in zip(c, a, strict=True))
              + f"); (c) - image-blind = {statistics.fmean(c) - blind:+.1f}")  # fmt: skip
        for name, row in models.items():
            if name.startswith("c_no_"):
                without = [r["mIoU"] for r in row["scores"][d]]
                summary[d][f"c_minus_{name}"] = round(statistics.fmean(c) - statistics.fmean(without), 2)  # fmt: skip
    result["summary"] = summary
    if "photos" in summary:
        s = summary["photos"]
        worst_se = max(mean_se([r["mIoU"] for r in row["scores"]["photos"]])[1]
                       for name, row in models.items() if name != "blind")  # fmt: skip
        print(f"targets on the held-out photo domain: (c) - (a) {s['c_minus_a']:+.1f} (>= +{TARGET_GAIN:.0f}), "
              f"(c) - blind {s['c_minus_blind']:+.1f} (>= +{TARGET_OVER_BLIND:.0f}), "
              f"largest standard error {worst_se:.1f} (< {TARGET_SE:.0f})")  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
