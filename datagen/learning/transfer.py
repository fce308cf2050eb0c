"""How well a model ranks the executed grasps of campaigns it was not trained on: ROC AUC over
all of them, over those the arm reached (every failure mode but ``unreachable``), the choice a
model is left with when the campaign checks reach (``campaign.check_reach``), and per target
class; calibration where its scores are probabilities."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from datagen.grasp_model.model_file import load_model
from datagen.learning.examples import GraspExamples, campaign_examples
from datagen.learning.metrics import auc_by_class, calibration, counted_auc, within_scene_auc

UNREACHED = "unreachable"


def campaign_auc(model_path: str | Path, campaign: str | Path, camera: str = "wrist") -> dict:
    """:func:`auc_by_reach` of the model's scores of the campaign's executed grasps, as
    ``camera`` saw them."""
    report = evaluate(model_path, [campaign], camera).report
    return {"all": report["all"], "reached": report["reached"]}


def reached_rows(modes: Sequence[str | None]) -> np.ndarray:
    """(N,) bool: the examples whose failure mode is not ``unreachable``."""
    return np.array([mode != UNREACHED for mode in modes], bool)


def auc_by_reach(scores: np.ndarray, success: np.ndarray, modes: Sequence[str | None]) -> dict:
    """{"all": {...}, "reached": {...}}: the examples (``n``), their successes and the ROC AUC
    of ``scores`` on them (None with one class only), over all examples and over those whose
    failure mode is not ``unreachable``."""
    reached = reached_rows(modes)
    scores, success = np.asarray(scores), np.asarray(success, bool)
    return {
        "all": counted_auc(scores, success),
        "reached": counted_auc(scores[reached], success[reached]),
    }


@dataclass
class Evaluation:
    report: dict  # what is printed and written as JSON
    scores: np.ndarray  # (N,) the model's score of each example
    examples: GraspExamples


def evaluate(
    model_path: str | Path,
    campaigns: Sequence[str | Path],
    camera: str = "wrist",
    on_progress: Callable[[int, int], None] | None = None,
) -> Evaluation:
    """The model's scores of the campaigns' executed grasps as ``camera`` saw them: ROC AUC over
    all, over those reached and per target class; calibration when every score is in [0, 1].
    ModelFileError for a file that breaks the contract, DatasetError for a folder that is not
    a campaign with that camera's depth."""
    model = load_model(model_path)
    examples = campaign_examples(campaigns, camera, model.crop_size, on_progress=on_progress)
    scores = model.score(examples.crops, examples.features) if len(examples) else np.zeros(0)
    report = {
        "model_sha256": model.sha256,
        "campaigns": [Path(c).name for c in campaigns],
        "camera": camera,
        "left_out": dict(sorted(examples.left_out.items())),
        **auc_by_reach(scores, examples.success, examples.modes),
        "classes": auc_by_class(scores, examples.success, examples.families),
        # the choice among one scene's candidates (campaigns with campaign.grasps_per_scene)
        "within_scene": within_scene_auc(scores, examples.success, examples.scene_names()),
    }
    if len(scores) and np.all((scores >= 0) & (scores <= 1)):  # probabilities
        report["calibration"] = calibration(scores, examples.success)
    return Evaluation(report, scores, examples)
