"""Object-level transfer: segmentation nets trained on each set's wrist-camera frames.

Does the randomisation transfer at the level of objects? A segmentation net users know is
trained from scratch on the wrist camera's frames of each training set, several seeds each, and
scored on how it finds the grasp targets in test domains built from sources no training set drew.

    .venv/bin/python benchmarks/object_transfer.py --quick    # minutes: 24 frames a set, 2 seeds
    .venv/bin/python benchmarks/object_transfer.py            # 2,000 frames a set, 3 seeds: hours

Frames: the wrist camera the arm holds over the tray (``render.wrist_camera: true``,
``robot.pose: look``, the defaults), 160x120 (``--size``), one per scene, built by the real
pipeline (``run_build``: workers, MQTT, writer, shards) into ``--out/builds/`` and read into
``--out/frames/*.npz``; a rerun reads what is there and continues an interrupted build. Classes:
``other`` (floor, walls, robot, gripper, distractors, background), ``table``, ``tray``,
``object`` (every grasp target), taken from each set's class list.

Training sets (``dr_transfer/variants.py``; equal sizes, the same seed and indices, training
texture families, lighting within the training band, photographs of the training sources):
flat (``configs/grasp_flat.yaml`` with the wrist camera over the tray), procedural (flat with
procedural textures and the room, no photographs), default, and the default without each of
issue 26's randomisers or of the object-level ones (textures on surfaces, household shapes,
the size range, clutter, the look's variety), and the default with 5 % of its views path-traced
(``object_domains.OBJECT_SETS``). Test domains (``dr_transfer/object_domains.py``; their own seed): the
default recipe with one held-out source each: photographs of the held-out library source, the
library's robosuite meshes (``objects.source: folder``), lighting outside the band, the
held-out texture families, path-traced colour (``render.shader: raytraced``; about 24 s a
160x120 view on a 2-core CPU, so its size is ``--raytraced-frames``).

Net (``--net``): torchvision's ``lraspp_mobilenet_v3_large(weights=None,
weights_backbone=None)`` where torchvision loads, else a small U-Net; AdamW, cosine schedule,
every batch mirrored and jittered (``dr_transfer/training.py``). Printed, one table per score:
IoU of object, object vs rest, instance recall at IoU 0.5, IoU of other, table and tray, as
mean ± standard error over the training seeds, with the image-blind baseline (each pixel's most
common class in the default set) scored the same way; then each set's cost per frame built and
per epoch trained. The CPU (model, cores, AVX-512 BF16) sets the precision (bfloat16 autocast
only where that flag is present and a quick check finds it faster) and the threads. Results go
to ``--out/results.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

from dr_transfer.building import build
from dr_transfer.frames import (
    SEGMENTATION_CLASSES,
    Frames,
    load_frames,
    read_frames,
    save_frames,
)
from dr_transfer.hardware import chosen_precision, commit, describe, device_named, this_cpu
from dr_transfer.nets import NETS, chosen_net
from dr_transfer.object_domains import (
    OBJECT_SETS,
    TEST_DOMAINS,
    wrist_test_domains,
    wrist_training_sets,
)
from dr_transfer.object_scores import object_scores
from dr_transfer.object_table import report
from dr_transfer.scoring import blind_prediction
from dr_transfer.training import BATCH, predict, train
from dr_transfer.variants import REPO

os.environ.setdefault("OMP_NUM_THREADS", "1")  # workers' BLAS threads busy-wait otherwise

FULL = {
    "frames": 2000,
    "test_frames": 300,
    "raytraced_frames": 40,
    "epochs": 20,
    "seeds": [0, 1, 2],
}
QUICK = {"frames": 24, "test_frames": 16, "raytraced_frames": 0, "epochs": 2, "seeds": [0, 1]}


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=f"minutes, not hours: {QUICK}")
    parser.add_argument("--frames", type=int, help=f"frames per training set ({FULL['frames']})")
    parser.add_argument(
        "--test-frames", type=int, help=f"frames per test domain ({FULL['test_frames']})"
    )
    parser.add_argument(
        "--raytraced-frames",
        type=int,
        help=f"frames of the path-traced domain ({FULL['raytraced_frames']}; 0: none)",
    )
    parser.add_argument("--epochs", type=int, help=f"training epochs ({FULL['epochs']})")
    parser.add_argument("--seeds", type=int, nargs="+", help=f"training seeds ({FULL['seeds']})")
    parser.add_argument("--size", default="160x120", help="frame width x height, pixels")
    parser.add_argument(
        "--only", nargs="+", choices=OBJECT_SETS, help="these training sets (default: all)"
    )
    parser.add_argument(
        "--net",
        choices=("auto", *NETS),
        default="auto",
        help="auto: lraspp where torchvision loads, else unet",
    )
    parser.add_argument(
        "--device",
        default="auto",
        help="torch device that trains: auto (cuda if there is one), cpu, cuda",
    )
    parser.add_argument(
        "--precision",
        choices=("auto", "fp32", "bf16"),
        default="auto",
        help="auto: bf16 on an AVX-512 BF16 CPU where it is faster",
    )
    parser.add_argument(
        "--threads", type=int, help="torch threads (default: the cores this process may use)"
    )
    parser.add_argument("--workers", type=int, default=2, help="build workers")
    parser.add_argument(
        "--build-only", action="store_true", help="build the sets and their frames, train nothing"
    )
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks/results/object_transfer")
    args = parser.parse_args()
    for name, value in (QUICK if args.quick else FULL).items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    width, height = args.size.split("x")
    args.frame_size = (int(width), int(height))
    return args


def set_frames(name: str, count: int, recipe: Callable[[], dict], args, costs: dict):
    """The ``count`` frames of one set or test domain, read from ``--out/frames`` or built from
    ``recipe()`` (a config dict) and kept there: where the frames are, neither datagen nor
    SAPIEN is needed. ``costs`` gets their count and what the build took (``build_s`` None:
    read)."""
    key = f"{name}-{count}"
    saved = args.out / "frames" / f"{key}.npz"
    costs.update(build_s=None)
    if saved.is_file():
        frames = load_frames(saved)
    else:
        built = build(f"object_transfer:{name}", recipe(), args.out / "builds" / key, args.workers)
        frames = read_frames(args.out / "builds" / key, args.frame_size, cameras=["wrist"])
        save_frames(frames, saved)
        if built:
            costs.update(
                build_s=round(built.seconds, 1),
                first_sample_s=round(built.first_sample_s, 1),
                steady_s_per_frame=built.steady_s_per_frame and round(built.steady_s_per_frame, 3),
            )
    costs["frames"] = len(frames)
    cost = f", built in {costs['build_s']:.0f} s" if costs["build_s"] else ", read from --out"
    print(f"{name:22} {len(frames)} frames{cost}", flush=True)
    return frames


def domain_recipe(args, name: str) -> dict:
    return wrist_test_domains(*args.frame_size, args.test_frames, args.raytraced_frames)[name]


def set_recipe(args, name: str) -> dict:
    return wrist_training_sets(*args.frame_size, args.frames)[name]


def test_domains(args, result: dict) -> dict[str, Frames]:
    counts = {name: args.test_frames for name in TEST_DOMAINS} | {
        "raytraced": args.raytraced_frames
    }
    return {
        name: set_frames(
            f"test_{name}",
            count,
            partial(domain_recipe, args, name),
            args,
            result["domains"].setdefault(name, {}),
        )
        for name, count in counts.items()
        if count > 0
    }


def blind_scores(prior: Frames, tests: dict[str, Frames], result: dict, seeds: int) -> dict:
    """The image-blind baseline on each test domain, once per seed (it has none: the same)."""
    scores = {}
    for name, frames in tests.items():
        blind = blind_prediction(prior.classes, len(frames))
        scores[name] = [object_scores(blind, frames.classes, frames.targets)] * seeds
        result["domains"][name]["instances"] = scores[name][0]["instances"]
    return scores


def trained_scores(
    name: str, frames: Frames, tests: dict, make_net, args, result: dict, costs: dict
):
    """One net per seed trained on set ``name``'s ``frames``, scored on each domain of ``tests``
    (domain -> float images on the training device, class maps, target maps). Each seed's
    scores are kept in ``--out/nets`` as soon as it is trained, so that a run stopped between
    seeds loses at most one net."""
    precision = result["precision"]["precision"]
    runs: dict[str, list] = {domain: [] for domain in tests}
    train_s, losses = 0.0, []
    x = y = None
    for seed in args.seeds:
        kept = earlier_net(args.out, result, name, len(frames), seed)
        if kept is None:
            if x is None:
                x, y = frames.float_images().to(args.device), frames.classes.to(args.device)
            start = time.perf_counter()
            trained, seed_losses = train(x, y, make_net, args.epochs, seed, precision=precision)
            scores = {
                domain: object_scores(predict(trained, tx, precision).cpu(), classes, targets)
                for domain, (tx, classes, targets) in tests.items()
            }
            kept = {"train_s": time.perf_counter() - start, "losses": seed_losses}
            kept |= {"scores": scores, "commit": result["commit"]}
            keep_net(args.out, result, name, len(frames), seed, kept)
        else:
            print(f"{name:22} seed {seed} trained by an earlier run: its scores kept", flush=True)
        train_s += kept["train_s"]
        losses.append(kept["losses"])
        for domain in tests:
            runs[domain].append(kept["scores"][domain])
    costs.update(
        train_s_per_epoch=round(train_s / args.epochs / len(args.seeds), 2),
        losses=losses,
        scores=runs,
    )
    objects = "  ".join(f"{d} {statistics.fmean(r['object'] for r in runs[d]):.1f}" for d in runs)
    print(
        f"{name:22} trained {costs['train_s_per_epoch']:.2f} s/epoch; IoU of object: {objects}",
        flush=True,
    )


def main() -> int:
    args = arguments()
    import torch

    cpu = this_cpu()
    threads = args.threads or cpu.cores
    torch.set_num_threads(threads)
    args.device = device_named(args.device)
    net, why = chosen_net(args.net)
    make_net = partial(NETS[net], len(SEGMENTATION_CLASSES))
    python = os.path.relpath(sys.executable) if sys.executable.startswith(os.getcwd()) else "python"
    result: dict = {
        "command": " ".join([python, *sys.argv]),
        "commit": commit(REPO),
        "cpu": describe(cpu),
        "threads": threads,
        "device": str(args.device),
        "net": {"name": net, "why": why},
        "size": list(args.frame_size),
        "epochs": args.epochs,
        "seeds": args.seeds,
        "domains": {},
    }
    print(f"{cpu.line()}; {threads} torch threads; {args.device}; net {net} ({why})", flush=True)
    tests = test_domains(args, result)
    names = [n for n in OBJECT_SETS if not args.only or n in args.only]
    result["sets"] = {name: {} for name in names}
    prior_costs = result["sets"].get("c_default", {})
    prior = set_frames(
        "c_default", args.frames, partial(set_recipe, args, "c_default"), args, prior_costs
    )
    if args.build_only:
        for name in names:
            set_frames(
                name, args.frames, partial(set_recipe, args, name), args, result["sets"][name]
            )
        return 0
    result["blind"] = blind_scores(prior, tests, result, len(args.seeds))
    on_device = {
        n: (f.float_images().to(args.device), f.classes, f.targets) for n, f in tests.items()
    }
    probe = prior.float_images()[:BATCH].to(args.device), prior.classes[:BATCH].to(args.device)
    result["precision"] = chosen_precision(args.precision, cpu, args.device, make_net, *probe)
    earlier = earlier_sets(args.out, result, args.frames)
    for name in names:
        if name in earlier:
            result["sets"][name] = earlier[name]
            print(
                f"{name:22} trained by an earlier run of this recipe: its scores kept", flush=True
            )
            continue
        costs = result["sets"][name]
        costs["commit"] = result["commit"]
        recipe = partial(set_recipe, args, name)
        frames = (
            prior if name == "c_default" else set_frames(name, args.frames, recipe, args, costs)
        )
        trained_scores(name, frames, on_device, make_net, args, result, costs)
        write(result, args.out)
    write(result, args.out)
    print("\n" + report(result), flush=True)
    return 0


RECIPE_KEYS = ("cpu", "device", "net", "size", "epochs", "seeds", "precision")


def _recipe(result: dict) -> list:
    """What a run's scores depend on; of the precision, the one chosen (the probe's speeds
    differ from run to run)."""
    precision = (result.get("precision") or {}).get("precision")
    return [result.get(key) for key in RECIPE_KEYS if key != "precision"] + [precision]


def earlier_sets(out: Path, result: dict, frames: int) -> dict[str, dict]:
    """The sets an earlier, interrupted run into ``out`` trained with this run's recipe (machine,
    net, size, epochs, seeds, precision, ``frames`` a set and the frame counts of every domain),
    so that a run of hours continues where it stopped; none when anything differs. Each set
    keeps the commit it was trained at."""
    try:
        earlier = json.loads((out / "results.json").read_text())
    except (OSError, ValueError):
        return {}
    if _recipe(earlier) != _recipe(result):
        return {}
    counts = {n: d.get("frames") for n, d in result["domains"].items()}
    if counts != {n: d.get("frames") for n, d in earlier.get("domains", {}).items()}:
        return {}
    return {
        name: costs
        for name, costs in earlier.get("sets", {}).items()
        if name in result["sets"] and "scores" in costs and costs.get("frames") == frames
    }


def _net_file(out: Path, name: str, seed: int) -> Path:
    return out / "nets" / f"{name}-seed{seed}.json"


def _net_recipe(result: dict, frames: int) -> list:
    """What one net's scores depend on: the run's recipe but its list of seeds."""
    counts = {n: d.get("frames") for n, d in result["domains"].items()}
    return [*_recipe(result | {"seeds": None}), frames, counts]


def earlier_net(out: Path, result: dict, name: str, frames: int, seed: int) -> dict | None:
    """Seed ``seed``'s net on set ``name`` as an earlier run of this recipe kept it (its
    training time, losses, scores per domain and commit); None when there is none or anything
    of the recipe differs."""
    try:
        kept = json.loads(_net_file(out, name, seed).read_text())
    except (OSError, ValueError):
        return None
    if kept.get("recipe") != _net_recipe(result, frames):
        return None
    if not all(domain in kept.get("scores", {}) for domain in result["domains"]):
        return None
    return kept


def keep_net(out: Path, result: dict, name: str, frames: int, seed: int, kept: dict) -> None:
    path = _net_file(out, name, seed)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial_file = path.with_suffix(".partial")
    partial_file.write_text(json.dumps(kept | {"recipe": _net_recipe(result, frames)}))
    partial_file.replace(path)


def write(result: dict, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    partial_file = out / "results.partial.json"
    partial_file.write_text(json.dumps(result, indent=1))
    partial_file.replace(out / "results.json")


if __name__ == "__main__":
    sys.exit(main())
