"""How well predicted success probabilities match outcomes: accuracy, ROC AUC and calibration.
Pure numpy and scipy."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.stats import rankdata

CALIBRATION_BINS = 10  # equal-width bins of predicted probability


def roc_auc(scores: np.ndarray, labels: np.ndarray) -> float | None:
    """The probability that a random success scores above a random failure (ties count half:
    the Mann-Whitney U statistic); None when one of the two is absent."""
    labels = np.asarray(labels, bool)
    positives, negatives = int(labels.sum()), int((~labels).sum())
    if positives == 0 or negatives == 0:
        return None
    ranks = rankdata(np.asarray(scores, float))
    return float((ranks[labels].sum() - positives * (positives + 1) / 2) / (positives * negatives))


def counted_auc(scores: np.ndarray, success: np.ndarray) -> dict:
    """{"n", "successes", "roc_auc"} (None with one class only) of ``scores`` on ``success``."""
    labels = np.asarray(success, bool)
    return {"n": len(labels), "successes": int(labels.sum()), "roc_auc": roc_auc(scores, labels)}


def auc_by_class(scores: np.ndarray, success: np.ndarray, classes: Sequence[str]) -> dict:
    """:func:`counted_auc` of each class's examples, by class name in order: classes differ in
    size, and one AUC over all of them can hide the class that matters."""
    names = np.asarray(classes, dtype=object)
    scores, success = np.asarray(scores), np.asarray(success, bool)
    return {c: counted_auc(scores[names == c], success[names == c]) for c in sorted(set(classes))}


def within_scene_auc(scores: np.ndarray, success: np.ndarray, scenes: Sequence[str]) -> dict:
    """Over every (held, failed) pair of examples tried in the same scene, the share the held
    one scores above (ties count half): how well the scores choose among one scene's
    candidates, which is what the learned sampler does. {"scenes": scenes with both outcomes,
    "pairs", "roc_auc"} (None without such a pair)."""
    scores, success = np.asarray(scores, float), np.asarray(success, bool)
    rows_of: dict[str, list[int]] = defaultdict(list)
    for row, name in enumerate(scenes):
        rows_of[name].append(row)
    right = pairs = mixed = 0.0
    for rows in rows_of.values():
        held, failed = scores[rows][success[rows]], scores[rows][~success[rows]]
        if len(held) and len(failed):
            mixed += 1
            pairs += len(held) * len(failed)
            diff = held[:, None] - failed[None, :]
            right += float((diff > 0).sum()) + 0.5 * float((diff == 0).sum())
    auc = round(right / pairs, 4) if pairs else None
    return {"scenes": int(mixed), "pairs": int(pairs), "roc_auc": auc}


def roc_curve(scores: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(false positive rate, true positive rate) at every threshold, from (0, 0) to (1, 1)."""
    labels = np.asarray(labels, bool)
    order = np.argsort(-np.asarray(scores, float), kind="stable")
    hits = np.concatenate([[0], np.cumsum(labels[order])])
    misses = np.concatenate([[0], np.cumsum(~labels[order])])
    return misses / max(1, int((~labels).sum())), hits / max(1, int(labels.sum()))


def calibration(probabilities: np.ndarray, labels: np.ndarray) -> dict:
    """Per bin of predicted probability: count, mean prediction, observed success rate; and the
    expected calibration error (their gap weighted by count) and the Brier score."""
    p, y = np.asarray(probabilities, float), np.asarray(labels, float)
    bins = np.minimum((p * CALIBRATION_BINS).astype(int), CALIBRATION_BINS - 1)
    rows: list[dict[str, Any]] = []
    gap = 0.0  # count-weighted |predicted - observed|
    for b in range(CALIBRATION_BINS):
        inside = bins == b
        if inside.any():
            gap += int(inside.sum()) * abs(float(p[inside].mean()) - float(y[inside].mean()))
            rows.append(
                {
                    "bin": [b / CALIBRATION_BINS, (b + 1) / CALIBRATION_BINS],
                    "count": int(inside.sum()),
                    "predicted": round(float(p[inside].mean()), 4),
                    "observed": round(float(y[inside].mean()), 4),
                }
            )
    ece = gap / max(1, len(p))
    return {"bins": rows, "ece": round(ece, 4), "brier": round(float(np.mean((p - y) ** 2)), 4)}


def scores_of(probabilities: np.ndarray, labels: np.ndarray) -> dict:
    """Accuracy at 0.5, ROC AUC, calibration, and the success rate a model must beat."""
    p, y = np.asarray(probabilities, float), np.asarray(labels, bool)
    auc = roc_auc(p, y)
    return {
        "examples": len(y),
        "success_rate": round(float(y.mean()), 4) if len(y) else None,
        "accuracy": round(float(((p >= 0.5) == y).mean()), 4) if len(y) else None,
        "roc_auc": None if auc is None else round(auc, 4),
        "calibration": calibration(p, y),
    }
