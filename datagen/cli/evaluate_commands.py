"""``datagen evaluate grasp``: how well a grasp model, yours or one ``datagen train grasp`` wrote,
ranks the executed grasps of campaigns it was not trained on (docs/campaigns.md, "Learning to
grasp"): a campaign of your own objects tells whether it transfers to them."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from datagen.cli.common import one_line
from datagen.cli.progress import LazyProgress
from datagen.cli.train_commands import CAMERAS, auc_text, class_lines, within_scene_lines


def add_parsers(commands) -> None:
    evaluate = commands.add_parser(
        "evaluate",
        help="score a model on datasets it was not trained on (a grasp model on grasp campaigns)",
        description="Measure a trained model on datasets datagen made.",
    )
    kinds = evaluate.add_subparsers(dest="kind", metavar="KIND", required=True)
    grasp = kinds.add_parser(
        "grasp",
        help="how well a grasp model ranks the executed grasps of campaigns",
        description="Scores every executed grasp of the campaigns with the model, as the learned "
        "sampler would have scored it, and prints the ROC AUC over all of them, over those the "
        "arm reached and per target class, and the calibration when the scores are "
        "probabilities.",
    )
    grasp.add_argument("campaigns", nargs="+", metavar="CAMPAIGN", help="campaign folders")
    grasp.add_argument(
        "--model", required=True, help="the model file (ONNX, docs/campaigns.md's contract)"
    )
    grasp.add_argument(
        "--camera",
        choices=CAMERAS,
        default="wrist",
        help="whose depth the model sees (the one it was trained on; default wrist)",
    )
    grasp.add_argument(
        "--out", help="also write the figures as JSON here (.json) and a picture beside it (.png)"
    )
    grasp.set_defaults(run=run_evaluate_grasp, command_parser=grasp)


def run_evaluate_grasp(args: argparse.Namespace) -> int:
    from datagen.errors import UserInputError
    from datagen.grasp_model.model_file import ModelFileError
    from datagen.learning.report import draw_evaluation
    from datagen.learning.transfer import evaluate

    out = Path(args.out) if args.out else None
    if out is not None and out.suffix != ".json":
        raise UserInputError(f"--out {one_line(args.out)}: expected a file name ending in .json")
    read = LazyProgress("attempts read", unit="attempts")
    try:
        evaluation = evaluate(args.model, args.campaigns, args.camera, on_progress=read)
    except ModelFileError as exc:
        raise UserInputError(f"--model: {exc}") from None
    finally:
        read.close()
    report = evaluation.report
    every, reached = report["all"], report["reached"]
    skipped = ", ".join(f"{n} {mode}" for mode, n in report["left_out"].items()) or "none"
    print(
        f"datagen: {every['n']} executed grasps ({every['successes']} held) from "
        f"{len(args.campaigns)} campaign(s), scored by {one_line(args.model)} "
        f"(sha256 {report['model_sha256'][:12]}); left out: {skipped}"
    )
    print(
        f"datagen: over all of them {auc_text(every)}; over the {reached['n']} the arm reached "
        f"({reached['successes']} held) {auc_text(reached)}"
    )
    for line in class_lines(report["classes"], "grasps") + within_scene_lines(
        report["within_scene"]
    ):
        print(line)
    if calibration := report.get("calibration"):
        print(
            f"datagen: the scores are probabilities: calibration error {calibration['ece']:.3f}, "
            f"Brier {calibration['brier']:.3f}"
        )
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(report, indent=1) + "\n")
        draw_evaluation(evaluation, out.with_suffix(".png"))
        print(f"datagen: wrote {out}, {out.with_suffix('.png')}")
    return 0
