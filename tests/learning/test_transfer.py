"""A model's ROC AUC on another campaign's grasps, over all of them and over those reached."""

from __future__ import annotations

import numpy as np
import pytest
from grasp_model_files import prefers_feature

from datagen.learning.examples import campaign_examples
from datagen.learning.metrics import roc_auc
from datagen.learning.transfer import auc_by_reach, campaign_auc


def test_unreachable_attempts_are_left_out_of_the_reached_score():
    # the model ranks reach perfectly (unreachable attempts score lowest) and holds at random
    scores = np.array([0.1, 0.2, 0.9, 0.8, 0.7, 0.6])
    success = np.array([False, False, True, False, True, False])
    modes = ["unreachable", "unreachable", None, "slipped", None, "missed"]
    auc = auc_by_reach(scores, success, modes)
    assert auc["all"] == {"n": 6, "successes": 2, "roc_auc": roc_auc(scores, success)}
    assert auc["all"]["roc_auc"] == 0.875  # 7 of the 8 success-failure pairs in order
    assert auc["reached"] == {"n": 4, "successes": 2, "roc_auc": 0.75}
    none_held = auc_by_reach(scores[:2], success[:2], modes[:2])
    assert none_held["all"]["roc_auc"] is None and none_held["reached"]["n"] == 0


@pytest.mark.sim
def test_a_model_file_is_scored_on_a_campaign_it_never_saw(campaign_dataset, tmp_path):
    model = prefers_feature(tmp_path / "width.onnx", column=1)  # the wider grasp first
    examples = campaign_examples([campaign_dataset], "wrist")
    auc = campaign_auc(model, campaign_dataset)
    assert auc == auc_by_reach(examples.features[:, 1], examples.success, examples.modes)
    assert auc["all"]["n"] == len(examples) > 0
    assert len(examples.modes) == len(examples)
    assert all(
        (mode is None) == held for mode, held in zip(examples.modes, examples.success, strict=True)
    )
