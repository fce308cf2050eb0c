"""A trained grasp model saved with what it is worth, to read and to look at: the ONNX file, its
held-out scores as JSON and a picture of its ROC curve, its calibration and its training loss."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from datagen.grasp_model.model_file import load_model
from datagen.learning.fit import Fitted, write_model
from datagen.learning.metrics import roc_curve
from datagen.learning.transfer import Evaluation, reached_rows


def save_model(fitted: Fitted, model: Path, facts: dict) -> tuple[str, Path, Path]:
    """Writes the net to ``model`` (ONNX), reads it back as the learned sampler will (its
    contract checked), then its report and picture beside it: (sha256, report, picture)."""
    write_model(fitted.net, model)
    loaded = load_model(model)
    facts = facts | {"model_sha256": loaded.sha256, "crop_size": loaded.crop_size}
    return (loaded.sha256, *write_report(fitted, model, facts))


def write_report(fitted: Fitted, model: Path, facts: dict) -> tuple[Path, Path]:
    """``<model>.json`` (``facts``, the held-out scores, the losses) and ``<model>.png``
    beside the model file; their paths."""
    record = facts | {"held_out": fitted.scores, "losses": [round(x, 5) for x in fitted.losses]}
    text, picture = model.with_suffix(".json"), model.with_suffix(".png")
    text.write_text(json.dumps(record, indent=1) + "\n")
    _draw(fitted, picture)
    return text, picture


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _roc(axes, scores: np.ndarray, success: np.ndarray, label: str, color: str) -> None:
    fpr, tpr = roc_curve(scores, success)
    axes.plot(fpr, tpr, color=color, label=label)
    axes.plot([0, 1], [0, 1], color="grey", linestyle=":")
    axes.set(xlabel="false positive rate", ylabel="true positive rate")


def _reliability(axes, calibration: dict) -> None:
    bins = calibration["bins"]
    axes.plot([0, 1], [0, 1], color="grey", linestyle=":")
    axes.scatter(
        [b["predicted"] for b in bins],
        [b["observed"] for b in bins],
        s=[10 + 2 * b["count"] for b in bins],
        color="tab:orange",
    )
    axes.set(
        title=f"calibration (ECE {calibration['ece']:.3f})",
        xlabel="predicted success",
        ylabel="observed success",
        xlim=(0, 1),
        ylim=(0, 1),
    )


def _draw(fitted: Fitted, path: Path) -> None:
    plt = _pyplot()
    scores = fitted.scores
    figure, (roc, calibration, loss) = plt.subplots(1, 3, figsize=(12, 3.8))
    _roc(roc, fitted.probabilities, fitted.held_out.success, "held out", "tab:blue")
    auc = scores["roc_auc"]
    roc.set(title=f"ROC, held out (AUC {auc:.3f})" if auc is not None else "ROC, held out")
    _reliability(calibration, scores["calibration"])
    loss.plot(np.arange(1, len(fitted.losses) + 1), fitted.losses, color="tab:green")
    loss.set(title="training loss", xlabel="epoch", ylabel="weighted cross-entropy")
    figure.tight_layout()
    figure.savefig(path, dpi=80)
    plt.close(figure)


def draw_evaluation(evaluation: Evaluation, path: Path) -> None:
    """ROC curves over all grasps and over those reached, ROC AUC per target class, and the
    calibration where the scores are probabilities."""
    plt = _pyplot()
    report, scores, examples = evaluation.report, evaluation.scores, evaluation.examples
    calibration = report.get("calibration")
    figure, panels = plt.subplots(
        1, 3 if calibration else 2, figsize=(12 if calibration else 8, 3.8)
    )
    reached = reached_rows(examples.modes)
    for rows, name, color in ((slice(None), "all", "tab:blue"), (reached, "reached", "tab:purple")):
        auc = report[name]["roc_auc"]
        label = f"{name} (n {report[name]['n']}, AUC {auc:.3f})" if auc is not None else name
        _roc(panels[0], scores[rows], examples.success[rows], label, color)
    panels[0].set(title="ROC")
    panels[0].legend(loc="lower right", fontsize=8)
    classes = {k: v for k, v in report["classes"].items() if v["roc_auc"] is not None}
    panels[1].barh(list(classes), [v["roc_auc"] for v in classes.values()], color="tab:blue")
    panels[1].axvline(0.5, color="grey", linestyle=":")
    panels[1].set(title="ROC AUC per target class", xlim=(0, 1))
    panels[1].set_yticks(range(len(classes)), [f"{k} (n {v['n']})" for k, v in classes.items()])
    if calibration:
        _reliability(panels[2], calibration)
    figure.tight_layout()
    figure.savefig(path, dpi=80)
    plt.close(figure)
