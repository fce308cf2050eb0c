"""How well a model ranks the executed grasps of a campaign it was not trained on: ROC AUC over
all of them, and over those the arm reached (every failure mode but ``unreachable``), the choice
a model is left with when the campaign checks reach (``campaign.check_reach``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from datagen.grasp_model.model_file import load_model
from datagen.learning.examples import campaign_examples
from datagen.learning.metrics import roc_auc

UNREACHED = "unreachable"


def campaign_auc(model_path: str | Path, campaign: str | Path, camera: str = "wrist") -> dict:
    """:func:`auc_by_reach` of the model's scores of the campaign's executed grasps, as
    ``camera`` saw them."""
    model = load_model(model_path)
    examples = campaign_examples([campaign], camera, size=model.crop_size)
    scores = model.score(examples.crops, examples.features)
    return auc_by_reach(scores, examples.success, examples.modes)


def auc_by_reach(scores: np.ndarray, success: np.ndarray, modes: Sequence[str | None]) -> dict:
    """{"all": {...}, "reached": {...}}: the examples (``n``), their successes and the ROC AUC
    of ``scores`` on them (None with one class only), over all examples and over those whose
    failure mode is not ``unreachable``."""
    reached = np.array([mode != UNREACHED for mode in modes], bool)
    out = {}
    for name, rows in (("all", np.ones(len(reached), bool)), ("reached", reached)):
        labels = np.asarray(success, bool)[rows]
        out[name] = {
            "n": len(labels),
            "successes": int(labels.sum()),
            "roc_auc": roc_auc(np.asarray(scores)[rows], labels),
        }
    return out
