"""Optical flow as a KITTI 16-bit PNG (the encoding KITTI's flow benchmark and most flow tools
read): channel R = u * 64 + 2^15, G = v * 64 + 2^15, B = valid (0 or 1); u, v in pixels (x right,
y down), to a 64th of a pixel. OpenCV reads and writes B, G, R: these functions take and give
OpenCV's order."""

from __future__ import annotations

import numpy as np

from datagen.dataset.manifest import DatasetError

KITTI_SCALE = 64.0  # flow units per pixel
KITTI_OFFSET = 2**15


def encode_kitti(flow: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint16 in OpenCV's B, G, R order from flow (H, W, 2) and valid (H, W)."""
    u = np.clip(np.round(flow[..., 0] * KITTI_SCALE + KITTI_OFFSET), 0, 65535)
    v = np.clip(np.round(flow[..., 1] * KITTI_SCALE + KITTI_OFFSET), 0, 65535)
    return np.stack([valid.astype(np.uint16), v.astype(np.uint16), u.astype(np.uint16)], axis=-1)


def decode_kitti(bgr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(flow (H, W, 2) float32, valid (H, W) bool) from an image read by OpenCV with
    ``cv2.IMREAD_UNCHANGED``."""
    flow = (bgr[..., [2, 1]].astype(np.float32) - KITTI_OFFSET) / KITTI_SCALE
    return flow, bgr[..., 0] > 0


def decode_flow_image(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`decode_kitti` of a decoded PNG, DatasetError unless it is 16-bit with 3 channels."""
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint16:
        raise DatasetError(
            f"a flow part is {image.dtype} {image.shape}, not a KITTI 16-bit RGB PNG"
        )
    return decode_kitti(image)
