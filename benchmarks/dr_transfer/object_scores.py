"""How well a predicted class map finds the grasp targets: IoU of each class, object versus
rest, and the share of target instances found.

A target instance counts as found when one connected region (8-connected) of the pixels
predicted ``object`` overlaps its mask in the instance map with IoU >= 0.5; every target with
at least one pixel in a frame's instance map counts. Objects that touch merge into one region,
so a class map finds them only as far as its regions keep them apart."""

from __future__ import annotations

from dr_transfer.frames import SEGMENTATION_CLASSES
from dr_transfer.scoring import iou

FOUND_AT_IOU = 0.5
OBJECT = SEGMENTATION_CLASSES.index("object")


def object_scores(predicted, classes, targets) -> dict[str, float]:
    """Percent scores over all frames of ``predicted`` and ``classes`` (N, H, W) class indices
    and ``targets`` (N, H, W) target instance ids: IoU of each class and their ``mIoU``,
    ``object_vs_rest`` (the mean IoU of the two classes object and not-object) and
    ``instance_recall``; ``instances``, how many target instances there were."""
    scores = iou(predicted, classes)
    is_object = predicted == OBJECT
    rest, truly_rest = ~is_object, classes != OBJECT
    rest_iou = 100 * (rest & truly_rest).sum().item() / max((rest | truly_rest).sum().item(), 1)
    scores["object_vs_rest"] = round((scores["object"] + rest_iou) / 2, 2)
    found, instances = found_instances(is_object.cpu().numpy(), targets.cpu().numpy())
    scores["instance_recall"] = round(100 * found / max(instances, 1), 2)
    scores["instances"] = instances
    return scores


def found_instances(object_masks, targets) -> tuple[int, int]:
    """(target instances found, target instances) over frames of bool ``object_masks`` and
    instance ids ``targets``, both (N, H, W) numpy arrays."""
    import cv2
    import numpy as np

    found = total = 0
    for mask, ids in zip(object_masks, targets, strict=True):
        count, regions = cv2.connectedComponents(mask.astype(np.uint8), connectivity=8)
        region_area = np.bincount(regions.ravel(), minlength=count)
        for instance in np.unique(ids[ids > 0]):
            inside = ids == instance
            overlap = np.bincount(regions[inside], minlength=count)
            overlap[0] = 0  # region 0 is everything not predicted object
            union = inside.sum() + region_area - overlap
            found += bool((overlap / union).max() >= FOUND_AT_IOU)
            total += 1
    return found, total
