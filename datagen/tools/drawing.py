"""Drawing helpers shared by the preview tiles (:mod:`datagen.tools.preview`,
:mod:`datagen.tools.aerial_preview`): BGR images, OpenCV."""

from __future__ import annotations

import cv2
import numpy as np


def instance_colour(instance_id: int) -> tuple[int, int, int]:
    """A stable, distinct BGR colour per instance id (golden-ratio hue steps)."""
    hue = int((instance_id * 0.618033988749895 % 1.0) * 179)
    hsv = np.uint8([[[hue, 200, 255]]])
    return tuple(int(c) for c in cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0])


def put_label(image: np.ndarray, text: str, origin: tuple[int, int], scale: float) -> None:
    """White text with a dark outline, readable on any background."""
    for colour, thickness in (((0, 0, 0), 3), ((255, 255, 255), 1)):
        cv2.putText(
            image, text, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv2.LINE_AA
        )


def depth_colour(depth_mm: np.ndarray) -> np.ndarray:
    valid = depth_mm > 0
    if not valid.any():
        return np.zeros((*depth_mm.shape, 3), np.uint8)
    lo, hi = np.percentile(depth_mm[valid], [1, 99])
    scaled = np.clip((depth_mm.astype(float) - lo) / max(hi - lo, 1.0), 0, 1)
    image = cv2.applyColorMap((255 * (1 - scaled)).astype(np.uint8), cv2.COLORMAP_TURBO)
    image[~valid] = 0
    return image


def fit(image: np.ndarray, height: int, width: int) -> np.ndarray:
    """``image`` scaled to fit (height, width), centred on black."""
    scale = min(height / image.shape[0], width / image.shape[1])
    resized = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    out = np.zeros((height, width, 3), np.uint8)
    y, x = (height - resized.shape[0]) // 2, (width - resized.shape[1]) // 2
    out[y : y + resized.shape[0], x : x + resized.shape[1]] = resized
    return out
