"""How far a grasp model carries to shapes it never saw, measured inside one training campaign:
nets trained on the attempts of all but some shape families and scored on the attempts of those
families (leave-families-out). With it beside the score on another object set (real meshes, say),
a user can tell a model that has not learned enough from one whose training shapes are too far
from the new ones: the first gains on held-out families as the campaign grows, the second gains
there and not on the new set."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from datagen.learning.examples import GraspExamples
from datagen.learning.fit import predict, train_net
from datagen.learning.metrics import auc_by_class, counted_auc
from datagen.seeding import sample_rng


def family_splits(families: Sequence[str], held: int, count: int, seed: int) -> list[list[str]]:
    """``count`` sets of ``held`` family names each, drawn from the
    ``grasp_model.family_split`` stream of (``seed``, split number)."""
    names = sorted(set(families))
    if not 0 < held < len(names):
        raise ValueError(
            f"{held} families held out of {len(names)} ({', '.join(names)}): expected at "
            "least one held out and one left to train on"
        )
    return [
        sorted(sample_rng(seed, k, "grasp_model.family_split").choice(names, held, replace=False))
        for k in range(count)
    ]


def held_out_family_auc(
    training: GraspExamples, scored: GraspExamples, held: Sequence[str], epochs: int, seed: int
) -> dict:
    """A net trained on the examples of ``training`` whose family is not in ``held``, scored on
    the examples of ``scored`` whose family is: {"held", "train_examples", "n", "successes",
    "roc_auc", "classes"} (ROC AUC None, and no net trained, where either side has one
    outcome only)."""
    learn = np.flatnonzero(~np.isin(training.families, held))
    rows = np.flatnonzero(np.isin(scored.families, held))
    test = scored.subset(rows)
    record = {"held": list(held), "train_examples": len(learn)}
    if len(set(training.success[learn].tolist())) < 2 or len(set(test.success.tolist())) < 2:
        return record | counted_auc(np.zeros(len(test)), test.success) | {"roc_auc": None}
    net, _ = train_net(training.subset(learn), epochs, seed)
    scores = predict(net, test.crops, test.features)
    return (
        record
        | counted_auc(scores, test.success)
        | {"classes": auc_by_class(scores, test.success, test.families)}
    )


def auc_standard_error(auc: float, successes: int, failures: int) -> float:
    """The standard error of a ROC AUC over ``successes`` and ``failures`` examples (Hanley and
    McNeil, 1982): how much it would move on another draw of as many examples."""
    q1, q2 = auc / (2 - auc), 2 * auc**2 / (1 + auc)
    variance = (
        auc * (1 - auc) + (successes - 1) * (q1 - auc**2) + (failures - 1) * (q2 - auc**2)
    ) / (successes * failures)
    return float(np.sqrt(max(variance, 0.0)))
