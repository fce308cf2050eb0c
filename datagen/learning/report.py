"""A trained grasp model saved with what it is worth, to read and to look at: the ONNX file, its
held-out scores as JSON and a picture of its ROC curve, its calibration and its training loss."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from datagen.grasp_model.model_file import load_model
from datagen.learning.fit import Fitted, write_model
from datagen.learning.metrics import roc_curve


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


def _draw(fitted: Fitted, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scores = fitted.scores
    figure, (roc, calibration, loss) = plt.subplots(1, 3, figsize=(12, 3.8))
    fpr, tpr = roc_curve(fitted.probabilities, fitted.held_out.success)
    roc.plot(fpr, tpr, color="tab:blue")
    roc.plot([0, 1], [0, 1], color="grey", linestyle=":")
    auc = scores["roc_auc"]
    roc.set(
        title=f"ROC, held out (AUC {auc:.3f})" if auc is not None else "ROC, held out",
        xlabel="false positive rate",
        ylabel="true positive rate",
    )
    bins = scores["calibration"]["bins"]
    calibration.plot([0, 1], [0, 1], color="grey", linestyle=":")
    calibration.scatter(
        [b["predicted"] for b in bins],
        [b["observed"] for b in bins],
        s=[10 + 2 * b["count"] for b in bins],
        color="tab:orange",
    )
    calibration.set(
        title=f"calibration (ECE {scores['calibration']['ece']:.3f})",
        xlabel="predicted success",
        ylabel="observed success",
        xlim=(0, 1),
        ylim=(0, 1),
    )
    loss.plot(np.arange(1, len(fitted.losses) + 1), fitted.losses, color="tab:green")
    loss.set(title="training loss", xlabel="epoch", ylabel="weighted cross-entropy")
    figure.tight_layout()
    figure.savefig(path, dpi=80)
    plt.close(figure)
