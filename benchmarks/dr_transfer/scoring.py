"""Scores of a predicted class map against the true one, the image-blind baseline, and the
mean ± standard error over training seeds."""

from __future__ import annotations

import statistics

from dr_transfer.frames import SEGMENTATION_CLASSES


def iou(predicted, y) -> dict[str, float]:
    """IoU of each class over all frames together, percent, and their mean ``mIoU``."""
    scores = {}
    for c, name in enumerate(SEGMENTATION_CLASSES):
        union = ((predicted == c) | (y == c)).sum().item()
        scores[name] = round(100 * ((predicted == c) & (y == c)).sum().item() / max(union, 1), 2)
    mean = sum(scores[n] for n in SEGMENTATION_CLASSES) / len(SEGMENTATION_CLASSES)
    scores["mIoU"] = round(mean, 2)
    return scores


def blind_prediction(y_train, count: int):
    """Each pixel's most common class over a training set, for ``count`` images: what a net
    that ignores the image predicts."""
    import torch

    counts = torch.stack([(y_train == c).sum(0) for c in range(len(SEGMENTATION_CLASSES))])
    return counts.argmax(0).expand(count, -1, -1)


def mean_se(values: list[float]) -> tuple[float, float]:
    if len(values) < 2:
        return values[0], float("nan")
    return statistics.fmean(values), statistics.stdev(values) / len(values) ** 0.5


def shown(values: list[float]) -> str:
    """``mean ± standard error``, one decimal."""
    mean, se = mean_se(values)
    return f"{mean:5.1f} ± {se:3.1f}"
