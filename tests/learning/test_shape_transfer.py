"""Transfer to shape families a net never saw: the splits, a net scored only on the families it
was not trained on, and the standard error of a ROC AUC against a simulation of it."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.grasp_model.inputs import GRASP_FEATURES
from datagen.learning.examples import GraspExamples
from datagen.learning.metrics import roc_auc
from datagen.learning.shape_transfer import (
    auc_standard_error,
    family_splits,
    held_out_family_auc,
)

FAMILIES = ["box", "can", "mug", "bowl"]


def planted(count: int, seed: int = 0, families=FAMILIES) -> GraspExamples:
    """Examples of several families whose success is whether the crop's left half is higher
    than the grasp: one rule for every family, so it carries to a family held out."""
    rng = np.random.default_rng(seed)
    crops = rng.normal(0.0, 0.01, (count, 1, 16, 16)).astype(np.float32)
    lifted = rng.random(count) < 0.5
    crops[lifted, 0, :, :8] -= 0.05
    features = rng.normal(0.0, 1.0, (count, GRASP_FEATURES)).astype(np.float32)
    names = [families[i % len(families)] for i in range(count)]
    return GraspExamples(crops, features, lifted, [f"a/{i}" for i in range(count)], names)


def test_splits_hold_out_distinct_families_drawn_from_the_seed():
    families = ["box", "can", "mug", "bowl", "tool", "box", "can"]
    splits = family_splits(families, 2, 6, seed=3)
    assert splits == family_splits(families, 2, 6, seed=3)
    assert splits != family_splits(families, 2, 6, seed=4)
    assert all(len(set(s)) == 2 and set(s) <= set(families) and s == sorted(s) for s in splits)
    assert family_splits(families, 2, 3, seed=3) == splits[:3]  # more splits add, never redraw


@pytest.mark.parametrize("held", [0, 5])
def test_holding_out_none_or_every_family_is_refused_naming_them(held):
    with pytest.raises(ValueError, match=f"{held} families held out of 5 .bowl, box, can"):
        family_splits(["box", "can", "mug", "bowl", "tool"], held, 2, seed=0)


def test_the_net_is_scored_only_on_the_families_it_never_trained_on():
    training, scored = planted(320), planted(160, seed=1)
    record = held_out_family_auc(training, scored, ["mug"], epochs=15, seed=0)
    assert record["held"] == ["mug"] and record["train_examples"] == 240  # box, can, bowl
    assert record["n"] == 40 and list(record["classes"]) == ["mug"]  # the mugs of ``scored``
    assert record["roc_auc"] > 0.85  # the rule is the same for mugs


def test_a_side_with_one_outcome_gets_no_auc_and_no_net():
    training, scored = planted(80), planted(40, seed=1)
    scored.success[np.isin(scored.families, ["mug"])] = True
    record = held_out_family_auc(training, scored, ["mug"], epochs=1, seed=0)
    assert record["roc_auc"] is None and record["n"] == 10 and "classes" not in record


def test_the_auc_standard_error_matches_the_spread_of_simulated_aucs():
    # Hanley and McNeil's table: AUC 0.9 over 50 successes and 50 failures, 0.0321
    assert auc_standard_error(0.9, 50, 50) == pytest.approx(0.0321, abs=5e-4)
    rng = np.random.default_rng(0)
    aucs = []
    for _ in range(2000):  # scores of 60 successes and 40 failures, 1 standard deviation apart
        scores = np.concatenate([rng.normal(1.0, 1.0, 60), rng.normal(0.0, 1.0, 40)])
        aucs.append(roc_auc(scores, np.arange(100) < 60))
    spread = float(np.std(aucs))
    assert auc_standard_error(float(np.mean(aucs)), 60, 40) == pytest.approx(spread, rel=0.1)
