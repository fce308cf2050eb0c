"""Where a learned grasp model's transfer stops: its ROC AUC on shape families it never saw,
inside one training campaign, beside its ROC AUC on another object set, as the campaign grows.

    .venv/bin/python benchmarks/grasp_shape_transfer.py --campaign CAMPAIGN --other OTHER

``CAMPAIGN`` is a grasp campaign of the procedural objects (``benchmarks/grasp_learning.py``
keeps its training campaigns under ``--out/campaigns``: ``<arm>-train-2000-x4``), ``OTHER``
campaigns of other objects (its held-out-objects antipodal campaign: the real robosuite meshes).
For each training size (``--curve``: the campaign's first N attempts): ``--splits`` nets, each
trained on the attempts of all but ``--held`` families and scored on every attempt of those
families (the families drawn per split from the build seed); and one net trained on all of the
first N, scored on OTHER's grasps the arm reached (the choice a model has with the reach
check). Printed: the held-out-families AUC, mean ± standard error over the splits, and per
family (families differ in size and difficulty); OTHER's AUC ± its Hanley-McNeil standard
error. Where the first rises with the campaign and the second does not, more attempts of these
shapes teach about new shapes of their kind but not about OTHER's: the training objects, not
the number of attempts, bound the model there. ``--quick`` runs it small, in a minute.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from dr_transfer.hardware import commit
from machine import cpu_model

REPO = Path(__file__).resolve().parents[1]
FULL = {"curve": [250, 1000, 2000], "splits": 8, "held": 4, "epochs": 40}
QUICK = {"curve": [8, 16], "splits": 2, "held": 1, "epochs": 3}


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--campaign", type=Path, required=True, help="the training campaign")
    parser.add_argument(
        "--other", type=Path, nargs="*", default=[], help="campaigns of other objects"
    )
    parser.add_argument("--quick", action="store_true", help=f"a minute: {QUICK}")
    parser.add_argument("--curve", type=int, nargs="+", help=f"training attempts ({FULL['curve']})")
    parser.add_argument("--splits", type=int, help=f"family splits per size ({FULL['splits']})")
    parser.add_argument("--held", type=int, help=f"families held out a split ({FULL['held']})")
    parser.add_argument("--epochs", type=int, help=f"training epochs ({FULL['epochs']})")
    parser.add_argument("--seed", type=int, default=0, help="draws the splits and the nets (0)")
    parser.add_argument("--out", type=Path, help="where results.json and the picture go")
    args = parser.parse_args()
    for name, value in (QUICK if args.quick else FULL).items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    args.curve = sorted(set(args.curve))
    return args


def other_auc(training, other, epochs: int, seed: int) -> dict | None:
    """The net trained on all of ``training``, scored on ``other``'s reached grasps."""
    from datagen.learning.fit import predict, train_net
    from datagen.learning.metrics import auc_by_class, counted_auc
    from datagen.learning.shape_transfer import auc_standard_error
    from datagen.learning.transfer import reached_rows

    if not len(other) or len(set(training.success.tolist())) < 2:
        return None
    net, _ = train_net(training, epochs, seed)
    reached = other.subset(np.flatnonzero(reached_rows(other.modes)))
    scores = predict(net, reached.crops, reached.features)
    record = counted_auc(scores, reached.success)
    record["classes"] = auc_by_class(scores, reached.success, reached.families)
    if record["roc_auc"] is not None:
        failures = record["n"] - record["successes"]
        record["se"] = auc_standard_error(record["roc_auc"], record["successes"], failures)
    return record


def mean_se(values: list[float]) -> tuple[float | None, float | None]:
    if not values:
        return None, None
    se = float(np.std(values, ddof=1) / np.sqrt(len(values))) if len(values) > 1 else None
    return float(np.mean(values)), se


def measure(args) -> dict:
    from datagen.learning.examples import campaign_examples
    from datagen.learning.shape_transfer import family_splits, held_out_family_auc

    everything = campaign_examples([args.campaign], "wrist")
    other = campaign_examples(args.other, "wrist") if args.other else None
    splits = family_splits(everything.families, args.held, args.splits, args.seed)
    sizes = []
    for size in args.curve:
        start = time.perf_counter()
        training = campaign_examples([args.campaign], "wrist", limit=size)
        runs = [
            held_out_family_auc(training, everything, held, args.epochs, args.seed + k)
            for k, held in enumerate(splits)
        ]
        row = {
            "attempts": size,
            "examples": len(training),
            "splits": runs,
            "other": other_auc(training, other, args.epochs, args.seed) if other else None,
        }
        row["seconds"] = round(time.perf_counter() - start, 1)
        sizes.append(row)
        print(line(row), flush=True)
    return {"families": sorted(set(everything.families)), "sizes": sizes}


def line(row: dict) -> str:
    mean, se = mean_se([r["roc_auc"] for r in row["splits"] if r["roc_auc"] is not None])
    text = f"{row['attempts']:>6} attempts ({row['examples']} examples): held-out families "
    text += "n/a" if mean is None else f"{mean:.3f}" + ("" if se is None else f" ± {se:.3f}")
    other = row["other"]
    if other and other["roc_auc"] is not None:
        text += f"; other objects {other['roc_auc']:.3f} ± {other['se']:.3f} (n {other['n']})"
    return text + f"  [{row['seconds']} s]"


def family_lines(result: dict) -> list[str]:
    """Per family, its AUC at each size, averaged over the splits that held it out."""
    lines = ["held-out family ROC AUC by training attempts (mean over the splits holding it out):"]
    lines.append(f"  {'family':12} " + " ".join(f"{r['attempts']:>7}" for r in result["sizes"]))
    for family in result["families"]:
        cells = []
        for row in result["sizes"]:
            aucs = [
                r["classes"][family]["roc_auc"]
                for r in row["splits"]
                if family in r.get("classes", {}) and r["classes"][family]["roc_auc"] is not None
            ]
            cells.append(f"{np.mean(aucs):7.3f}" if aucs else "    n/a")
        lines.append(f"  {family:12} " + " ".join(cells))
    others = [row["other"] for row in result["sizes"]]
    if all(others):
        lines.append("other objects' reached grasps, ROC AUC by class and training attempts:")
        for name, first in others[0]["classes"].items():
            cells = [other["classes"][name]["roc_auc"] for other in others]
            text = " ".join("    n/a" if c is None else f"{c:7.3f}" for c in cells)
            lines.append(f"  {name:12} " + text + f"  (n {first['n']})")
    return lines


def draw(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = [r["attempts"] for r in result["sizes"]]
    figure, axes = plt.subplots(figsize=(6, 4))
    held = [
        mean_se([s["roc_auc"] for s in r["splits"] if s["roc_auc"] is not None])
        for r in result["sizes"]
    ]
    axes.errorbar(
        sizes,
        [m for m, _ in held],
        [s or 0 for _, s in held],
        marker="o",
        label="held-out families",
    )
    others = [r["other"] for r in result["sizes"]]
    if all(o and o["roc_auc"] is not None for o in others):
        axes.errorbar(
            sizes,
            [o["roc_auc"] for o in others],
            [o["se"] for o in others],
            marker="s",
            label="other objects (reached)",
        )
    axes.axhline(0.5, color="grey", linestyle=":")
    axes.set(xscale="log", xlabel="training attempts", ylabel="ROC AUC")
    axes.set(title="grasps on shapes no training attempt tried")
    axes.set_xticks(sizes, [str(n) for n in sizes])
    axes.minorticks_off()
    axes.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def main() -> int:
    args = arguments()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import torch

    torch.set_num_threads(1)
    python = os.path.relpath(sys.executable) if sys.executable.startswith(os.getcwd()) else "python"
    header = {
        "command": " ".join([python, *sys.argv]),
        "commit": commit(REPO),
        "cpu": f"{cpu_model()}, {len(os.sched_getaffinity(0))} cores",
    }
    print(f"{header['cpu']}; {header['command']}; commit {header['commit']}", flush=True)
    from datagen.dataset.loader import DatasetError

    try:
        result = header | measure(args)
    except (DatasetError, ValueError) as error:  # not a campaign; too few families or outcomes
        print(f"grasp_shape_transfer: {error}", file=sys.stderr)
        return 2
    print("\n".join(family_lines(result)))
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "results.json").write_text(json.dumps(result, indent=1) + "\n")
        draw(result, args.out / "shape_transfer.png")
        print(f"results: {args.out / 'results.json'}, picture: {args.out / 'shape_transfer.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
