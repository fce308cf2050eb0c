"""``datagen train grasp``: a grasp-quality model trained on grasp campaigns, scored on attempts
it never saw and written as the ONNX file ``datagen campaign grasp --sampler learned --model``
loads (docs/campaigns.md, "Learning to grasp")."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from datagen.cli.common import one_line, whole_number
from datagen.cli.progress import LazyProgress

CAMERAS = ("wrist", "workspace")


def add_parsers(commands) -> None:
    train = commands.add_parser(
        "train",
        help="train a model on datasets (a grasp-quality model on grasp campaigns)",
        description="Learn from datasets datagen made.",
    )
    kinds = train.add_subparsers(dest="kind", metavar="KIND", required=True)
    grasp = kinds.add_parser(
        "grasp",
        help="a grasp-quality model from grasp campaigns, for the learned sampler",
        description="Turns each attempt of the campaigns into a depth crop around the executed "
        "grasp and its success, trains a small net on all but a held-out share, prints its "
        "held-out accuracy, ROC AUC and calibration, and writes the ONNX model with a report "
        "(.json) and a picture (.png) beside it.",
    )
    grasp.add_argument("campaigns", nargs="+", metavar="CAMPAIGN", help="campaign folders")
    grasp.add_argument("--out", required=True, help="the model file to write (.onnx)")
    grasp.add_argument(
        "--camera",
        choices=CAMERAS,
        default="wrist",
        help="whose depth the model sees (campaign.model_camera when it is used; default wrist)",
    )
    grasp.add_argument(
        "--epochs", type=whole_number(1, 10000), default=40, help="training epochs (40)"
    )
    grasp.add_argument(
        "--attempts",
        type=whole_number(1, 10**9),
        help="use only the first N attempts of each campaign (default: all)",
    )
    grasp.add_argument("--seed", type=whole_number(0, 2**31 - 1), default=0, help="seed (0)")
    grasp.add_argument(
        "--held-out",
        type=float,
        default=0.2,
        help="share of the attempts kept out of training and scored (0.2)",
    )
    grasp.set_defaults(run=run_train_grasp, command_parser=grasp)


def auc_text(counted: dict) -> str:
    """``ROC AUC 0.723`` of a ``datagen.learning.metrics.counted_auc`` (n/a with one class)."""
    auc = counted["roc_auc"]
    return f"ROC AUC {'n/a' if auc is None else f'{auc:.3f}'}"


def class_lines(classes: dict, noun: str) -> list[str]:
    """One line per target class of ``auc_by_class``: its ``noun`` (attempts, grasps), how many
    held and the ROC AUC."""
    return [
        f"datagen:   {name}: {c['n']} {noun}, {c['successes']} held, {auc_text(c)}"
        for name, c in classes.items()
    ]


def within_scene_lines(within: dict, which: str = "") -> list[str]:
    """The line of ``within_scene_auc``, where there is a pair to rank (campaigns with
    ``campaign.grasps_per_scene`` above 1); none otherwise."""
    if not within["pairs"]:
        return []
    return [
        f"datagen: within one scene ({within['scenes']} {which}scenes with held and failed "
        f"grasps, {within['pairs']} pairs): {auc_text(within)}"
    ]


def run_train_grasp(args: argparse.Namespace) -> int:
    from datagen.errors import UserInputError
    from datagen.learning.examples import campaign_examples
    from datagen.learning.fit import fit
    from datagen.learning.report import save_model

    out = Path(args.out)
    if out.suffix != ".onnx":
        raise UserInputError(f"--out {one_line(args.out)}: expected a file name ending in .onnx")
    if not 0.05 <= args.held_out <= 0.5:
        raise UserInputError(f"--held-out {args.held_out}: expected a share from 0.05 to 0.5")
    read = LazyProgress("attempts read", unit="attempts")
    examples = campaign_examples(args.campaigns, args.camera, limit=args.attempts, on_progress=read)
    read.close()
    skipped = ", ".join(f"{n} {mode}" for mode, n in examples.left_out.items()) or "none"
    print(
        f"datagen: {len(examples)} examples ({int(examples.success.sum())} successes) from "
        f"{len(args.campaigns)} campaign(s); left out: {skipped}"
    )
    start = time.perf_counter()

    def epoch(done: int, loss: float) -> None:
        if done == 1 or done % 10 == 0 or done == args.epochs:
            print(f"datagen: epoch {done}/{args.epochs}, training loss {loss:.4f}", flush=True)

    try:
        fitted = fit(examples, args.epochs, args.seed, args.held_out, on_epoch=epoch)
    except ValueError as exc:
        raise UserInputError(f"{', '.join(map(one_line, args.campaigns))}: {exc}") from None
    facts = {
        "campaigns": [Path(c).name for c in args.campaigns],
        "camera": args.camera,
        "epochs": args.epochs,
        "seed": args.seed,
        "train_s": round(time.perf_counter() - start, 1),
    }
    sha256, report, picture = save_model(fitted, out, facts)
    s = fitted.scores
    print(
        f"datagen: held out {s['examples']} attempts (success rate {s['success_rate']:.1%}): "
        f"accuracy {s['accuracy']:.1%}, {auc_text(s)}, calibration error "
        f"{s['calibration']['ece']:.3f}, Brier {s['calibration']['brier']:.3f}"
    )
    for line in class_lines(s["classes"], "attempts"):
        print(line)
    for line in within_scene_lines(s["within_scene"], "held-out "):
        print(line)
    print(f"datagen: wrote {out} (sha256 {sha256[:12]}), {report}, {picture}")
    print(
        f"datagen: use it: datagen campaign grasp CONFIG --sampler learned --model {out}"
        + ("" if args.camera == "wrist" else " (with campaign.model_camera: workspace)")
    )
    return 0
